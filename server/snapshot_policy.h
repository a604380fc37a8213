// When a mission asks for a snapshot of itself: once `every` measurements
// (or 4 x `every` records of any kind) were applied since the last stored
// one, and not again while the one asked for is still being written. The
// registry's snapshot writer (server/snapshot_writer.h) takes the snapshot
// and reports back through Done.
//
//   policy.Set(16, [this, id] { QueueSnapshot(id); });
//   policy.MaybeWant([&] { return SnapshotPolicy::Progress{measurements, last_sequence}; });
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>

#include "absl/functional/function_ref.h"

namespace oaipp::server {

class SnapshotPolicy {
 public:
  // How far the mission is: the measurements it fused and the sequence
  // number of the last record of its log.
  struct Progress {
    std::int64_t measurements_fused = 0;
    std::int64_t last_sequence = 0;
  };

  // Asks for a snapshot through `wanted` once `every` measurements (or 4 x
  // `every` records of any kind) were applied since the last stored one;
  // every <= 0 or no `wanted`: never. Set once, before the mission is
  // shared.
  void Set(int every, std::function<void()> wanted);
  // Recovery: the last stored snapshot covers the log up to `sequence`,
  // with `measurements_fused` measurements (before the mission is shared).
  void StoredAt(std::int64_t sequence, std::int64_t measurements_fused);
  // Calls `wanted` if a snapshot is due and none is pending. `progress` is
  // asked only when the policy is set and no snapshot is pending, so that a
  // mission without snapshots takes none of the locks it reads under.
  void MaybeWant(absl::FunctionRef<Progress()> progress);
  // The snapshot of the log up to `sequence` is durable (stored) or failed;
  // either way it is no longer pending.
  void Done(bool stored, std::int64_t sequence, std::int64_t measurements_fused);

 private:
  int every_ = 0;
  std::function<void()> wanted_;
  // What the last stored snapshot covered, and whether one is asked for and
  // not yet done.
  std::atomic<std::int64_t> sequence_{0};
  std::atomic<std::int64_t> measurements_{0};
  std::atomic<bool> pending_{false};
};

}  // namespace oaipp::server
