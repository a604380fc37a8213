// Admission to planning: a bounded pool, so that one heavy mission cannot
// starve the others and overload is refused instead of queued without bound.
//
//   PlanningGate gate(/*threads=*/2, /*queue=*/8);
//   OAIPP_RETURN_IF_ERROR(gate.Acquire(deadline));
//   ... plan ...
//   gate.Release();
#pragma once

#include "absl/status/status.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"

namespace oaipp::server {

// Planning admission: at most `threads` plans run at once and at most
// `queue` wait; beyond that callers are refused, not queued.
class PlanningGate {
 public:
  PlanningGate(int threads, int queue) : threads_(threads), queue_(queue) {}
  // OK when admitted (call Release after); ResourceExhausted when the queue
  // is full; DeadlineExceeded when `deadline` passes while waiting.
  [[nodiscard]] absl::Status Acquire(absl::Time deadline);
  void Release();
  [[nodiscard]] int running() const;

 private:
  mutable absl::Mutex mu_;
  int running_ ABSL_GUARDED_BY(mu_) = 0;
  int waiting_ ABSL_GUARDED_BY(mu_) = 0;
  const int threads_;
  const int queue_;
};

}  // namespace oaipp::server
