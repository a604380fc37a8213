// What a mission reports without waiting for a change or a plan (Snapshot,
// finished, MemoryBytes): the summary published at the end of every change,
// under its own lock, a leaf. A sparse map's trace may be newer than the
// change that published it: SettleMap refreshes it in the background, and a
// change publishing an older one keeps the newer.
//
//   PublishedSummary summary;
//   summary.Replace(next, /*sparse=*/false);
//   double trace = summary.Get().trace;
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "core/environment/environment.h"
#include "core/environment/obstacle.h"

namespace oaipp::server {

class PublishedSummary {
 public:
  struct Summary {
    std::shared_ptr<const std::vector<Obstacle>> obstacles;
    // The world as of this summary, for its ESDF's share of the memory.
    std::shared_ptr<const Environment> env;
    double trace = 0.0;
    std::int64_t trace_measurements_fused = 0;
    std::int64_t trace_version = 0;  // a sparse map's version of `trace`
    std::int64_t measurements_fused = 0;
    double mission_time_s = 0.0;
  };

  // A copy of the summary last published (its vectors shared, not copied).
  [[nodiscard]] Summary Get() const;
  // Publishes `next`; for a sparse map, the trace published stays when its
  // version is newer than next's (a background refresh, SetNewerTrace, may
  // have published a newer variance map).
  void Replace(Summary next, bool sparse);
  // A sparse map's trace from its variance map of `version`, when that is
  // newer than the trace published.
  void SetNewerTrace(double trace, std::int64_t measurements_fused, std::int64_t version);
  // Recovery: a snapshot's trace, until the next variance map.
  void RestoreTrace(double trace, std::int64_t measurements_fused);

 private:
  // Guards summary_.
  mutable absl::Mutex mu_;
  Summary summary_ ABSL_GUARDED_BY(mu_);
};

}  // namespace oaipp::server
