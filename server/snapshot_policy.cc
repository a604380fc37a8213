#include "server/snapshot_policy.h"

#include <utility>

namespace oaipp::server {

void SnapshotPolicy::Set(int every, std::function<void()> wanted) {
  every_ = every;
  wanted_ = std::move(wanted);
}

void SnapshotPolicy::StoredAt(std::int64_t sequence, std::int64_t measurements_fused) {
  sequence_ = sequence;
  measurements_ = measurements_fused;
}

void SnapshotPolicy::MaybeWant(absl::FunctionRef<Progress()> progress) {
  if (every_ <= 0 || !wanted_ || pending_.load()) return;
  const Progress now = progress();
  const std::int64_t records = now.last_sequence - sequence_.load();
  if (now.measurements_fused - measurements_.load() < every_ &&
      records < 4 * static_cast<std::int64_t>(every_)) {
    return;
  }
  if (pending_.exchange(true)) return;
  wanted_();
}

void SnapshotPolicy::Done(bool stored, std::int64_t sequence, std::int64_t measurements_fused) {
  if (stored && sequence > sequence_.load()) {
    sequence_ = sequence;
    measurements_ = measurements_fused;
  }
  pending_ = false;
}

}  // namespace oaipp::server
