#include "server/planning_gate.h"

#include "absl/strings/str_cat.h"

namespace oaipp::server {

absl::Status PlanningGate::Acquire(absl::Time deadline) {
  absl::MutexLock lock(&mu_);
  if (running_ < threads_) {
    ++running_;
    return absl::OkStatus();
  }
  if (waiting_ >= queue_) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "planner busy: ", running_, " plans running and ", waiting_, " waiting; retry later"));
  }
  ++waiting_;
  auto free = [this]() ABSL_SHARED_LOCKS_REQUIRED(mu_) { return running_ < threads_; };
  const bool admitted = mu_.AwaitWithDeadline(absl::Condition(&free), deadline);
  --waiting_;
  if (!admitted) return absl::DeadlineExceededError("deadline passed while waiting for a planner");
  ++running_;
  return absl::OkStatus();
}

void PlanningGate::Release() {
  absl::MutexLock lock(&mu_);
  --running_;
}

int PlanningGate::running() const {
  absl::MutexLock lock(&mu_);
  return running_;
}

}  // namespace oaipp::server
