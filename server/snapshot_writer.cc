#include "server/snapshot_writer.h"

#include <memory>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/registry.h"
#include "server/store/state_codec.h"
#include "spdlog/spdlog.h"

namespace oaipp::server {

SnapshotWriter::~SnapshotWriter() { Stop(); }

void SnapshotWriter::Start(std::function<void(const std::string& mission_id)> write) {
  write_ = std::move(write);
  thread_ = std::thread([this] { Loop(); });
}

void SnapshotWriter::Queue(const std::string& mission_id) {
  absl::MutexLock lock(&mu_);
  if (!stopping_) queue_.push_back(mission_id);
}

void SnapshotWriter::Loop() {
  while (true) {
    std::string id;
    {
      absl::MutexLock lock(&mu_);
      const auto ready = [this]() ABSL_SHARED_LOCKS_REQUIRED(mu_) {
        return stopping_ || !queue_.empty();
      };
      mu_.Await(absl::Condition(&ready));
      if (stopping_) return;
      id = std::move(queue_.front());
      queue_.pop_front();
      busy_ = true;
    }
    write_(id);
    absl::MutexLock lock(&mu_);
    busy_ = false;
  }
}

void SnapshotWriter::Flush() {
  absl::MutexLock lock(&mu_);
  const auto idle = [this]() ABSL_SHARED_LOCKS_REQUIRED(mu_) {
    return stopping_ || (queue_.empty() && !busy_);
  };
  mu_.Await(absl::Condition(&idle));
}

void SnapshotWriter::CountWritten() {
  absl::MutexLock lock(&mu_);
  ++written_;
}

std::int64_t SnapshotWriter::written() const {
  absl::MutexLock lock(&mu_);
  return written_;
}

void SnapshotWriter::Stop() {
  {
    absl::MutexLock lock(&mu_);
    stopping_ = true;
  }
  if (thread_.joinable()) thread_.join();
}

// The registry's side: which missions ask for snapshots, and how one is
// taken and stored.

void MissionRegistry::WatchForSnapshots(Mission& mission) {
  if (snapshots_.running()) {
    mission.SetSnapshotPolicy(limits_.snapshot_every,
                              [this, id = mission.id()] { snapshots_.Queue(id); });
  }
}

void MissionRegistry::TakeSnapshot(const std::string& mission_id) {
  absl::MutexLock write_lock(&snapshot_write_mu_);
  std::shared_ptr<Mission> mission;
  {
    absl::MutexLock lock(&mu_);
    auto it = missions_.find(mission_id);
    if (it == missions_.end() || it->second == nullptr) return;  // deleted meanwhile
    mission = it->second;
  }
  const MissionState state = mission->CaptureState();
  const absl::Status stored = store_->PutSnapshot(mission_id, {.sequence = state.sequence,
                                                               .state = EncodeMissionState(state),
                                                               .epoch = mission->lease().epoch()});
  if (stored.GetPayload(kFenced).has_value()) {
    Drop(mission_id, mission,
         absl::UnavailableError(absl::StrCat("name: mission 'missions/", PublicId(mission_id),
                                             "' moved to another server; watch it again")));
    return;
  }
  if (!stored.ok()) {
    spdlog::warn("store: snapshot of mission '{}' at record {}: {}", mission_id, state.sequence,
                 stored.ToString());
  } else {
    snapshots_.CountWritten();
  }
  mission->SnapshotDone(stored.ok(), state.sequence, state.measurements_fused);
}

void MissionRegistry::FlushSnapshots() { snapshots_.Flush(); }

std::int64_t MissionRegistry::snapshots_written() const { return snapshots_.written(); }

}  // namespace oaipp::server
