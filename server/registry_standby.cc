// Warm standbys (docs/cluster.md): a replica of a cluster keeps, read and
// replayed ahead of time, the missions the proxies would send it if their
// holder died, so that a takeover claims and replays only the records
// written since its last look instead of reading a snapshot of megabytes
// and replaying a log tail while the UAV hovers.
#include <algorithm>
#include <iterator>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "absl/time/clock.h"
#include "core/common/status_macros.h"
#include "server/hash_ring.h"
#include "server/registry.h"
#include "spdlog/spdlog.h"

namespace oaipp::server {

void MissionRegistry::KeepStandbys() {
  if (!shares_store() || limits_.ring_id <= 0) return;
  const absl::StatusOr<StoreView> view =
      store_->View(LeaseName(""), absl::ToUnixMicros(absl::Now()));
  if (!view.ok()) {
    spdlog::debug("standby: {}", view.status().ToString());
    return;
  }
  // The ring as the proxies have it now (the live servers on it), and
  // without each holder: where the holder's missions go when it dies. A
  // mission whose holder has died stays on standby here until a call for
  // it comes (that is when it is needed).
  std::vector<int> ring = {limits_.ring_id};
  for (const StoreView::Alive& alive : view->alive) {
    if (alive.ring_id > 0 && alive.holder != limits_.holder) ring.push_back(alive.ring_id);
  }
  std::map<int, HashRing> without;
  std::map<std::string, std::int64_t> wanted;  // key -> last sequence stored
  for (const StoreView::Held& held : view->held) {
    // This server's own, or a holder the proxies do not know.
    if (held.holder == limits_.holder || held.holder_ring_id <= 0) continue;
    auto [it, added] = without.try_emplace(held.holder_ring_id, std::vector<int>{});
    if (added) {
      std::vector<int> others;
      std::copy_if(ring.begin(), ring.end(), std::back_inserter(others),
                   [&](int id) { return id != held.holder_ring_id; });
      it->second = HashRing(others);
    }
    if (it->second.Pick(HashRing::RouteHash(PublicId(held.mission_id))) != limits_.ring_id) {
      continue;
    }
    wanted[held.mission_id] = held.last_sequence;
    if (static_cast<int>(wanted.size()) >= limits_.max_standbys) break;
  }
  std::vector<std::pair<std::string, std::shared_ptr<Standby>>> work;
  {
    absl::MutexLock lock(&mu_);
    std::int64_t room = limits_.max_memory_bytes > 0 ? limits_.max_memory_bytes - ReservedBytes()
                                                     : std::numeric_limits<std::int64_t>::max();
    for (auto it = standbys_.begin(); it != standbys_.end();) {
      // Kept while wanted, not held here, and within the memory left.
      const bool keep =
          wanted.contains(it->first) && !missions_.contains(it->first) && it->second->bytes <= room;
      if (keep) room -= it->second->bytes;
      it = keep ? std::next(it) : standbys_.erase(it);
    }
    for (const auto& [key, last_sequence] : wanted) {
      if (missions_.contains(key) || takeovers_in_progress_.contains(key)) continue;
      std::shared_ptr<Standby>& slot = standbys_[key];
      if (slot == nullptr) slot = std::make_shared<Standby>();
      work.emplace_back(key, slot);
    }
  }
  for (const auto& [key, standby] : work) {
    absl::Status followed;
    {
      absl::MutexLock lock(&standby->mu);
      if (standby->taken) continue;  // a takeover is reading it already
      followed = Follow(key, *standby, wanted[key]);
      if (!followed.ok()) standby->read.reset();
    }
    if (!followed.ok()) {
      spdlog::debug("standby: mission 'missions/{}': {}", std::string(PublicId(key)),
                    followed.ToString());
      absl::MutexLock lock(&mu_);
      if (auto it = standbys_.find(key); it != standbys_.end() && it->second == standby) {
        standbys_.erase(it);
      }
    }
  }
}

absl::Status MissionRegistry::Follow(const std::string& key, Standby& standby,
                                     std::int64_t last_sequence) {
  if (!standby.read.has_value()) {
    OAIPP_ASSIGN_OR_RETURN(ReadBack read, Prefetch(key));
    const std::int64_t bytes = EstimateMissionBytes(read.mission->config()).total();
    {
      absl::MutexLock lock(&mu_);
      if (limits_.max_memory_bytes > 0 &&
          ReservedBytes() + StandbyBytes() + bytes > limits_.max_memory_bytes) {
        return absl::ResourceExhaustedError("no memory left to stand by for it");
      }
      standby.bytes = bytes;
    }
    standby.read = std::move(read);
    return absl::OkStatus();
  }
  const std::int64_t have = standby.read->mission->next_sequence() - 1;
  if (last_sequence <= have) return absl::OkStatus();
  OAIPP_ASSIGN_OR_RETURN(StoredMission stored, store_->LoadAfter(key, have));
  if (stored.snapshot.has_value()) {
    // A snapshot covers records this standby never saw (they are gone).
    OAIPP_ASSIGN_OR_RETURN(ReadBack read, ReadBackBase(stored));
    OAIPP_RETURN_IF_ERROR(ReplayRecords(read, stored.log));
    standby.read = std::move(read);
    return absl::OkStatus();
  }
  return ReplayRecords(*standby.read, stored.log);
}

std::shared_ptr<MissionRegistry::Standby> MissionRegistry::TakeStandby(const std::string& key) {
  absl::MutexLock lock(&mu_);
  auto it = standbys_.find(key);
  if (it == standbys_.end()) return nullptr;
  std::shared_ptr<Standby> standby = std::move(it->second);
  standbys_.erase(it);
  return standby;
}

void MissionRegistry::TrimStandbys() {
  if (limits_.max_memory_bytes <= 0 || standbys_.empty()) return;
  std::int64_t standing = StandbyBytes();
  const std::int64_t reserved = ReservedBytes();
  while (!standbys_.empty() && reserved + standing > limits_.max_memory_bytes) {
    const auto last = std::prev(standbys_.end());
    standing -= last->second->bytes;
    standbys_.erase(last);
  }
}

std::int64_t MissionRegistry::StandbyBytes() const {
  std::int64_t total = 0;
  for (const auto& [key, standby] : standbys_) total += standby->bytes;
  return total;
}

int MissionRegistry::standbys() const {
  absl::MutexLock lock(&mu_);
  return static_cast<int>(standbys_.size());
}

std::int64_t MissionRegistry::takeovers_from_standby() const {
  absl::MutexLock lock(&mu_);
  return takeovers_from_standby_;
}

}  // namespace oaipp::server
