#include "server/planning_gate.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"

namespace oaipp::server {

PlanningGate::Ticket& PlanningGate::Ticket::operator=(Ticket&& other) noexcept {
  if (this != &other) {
    Release();
    gate_ = other.gate_;
    other.gate_ = nullptr;
  }
  return *this;
}

void PlanningGate::Ticket::Release() {
  if (gate_ != nullptr) gate_->Leave();
  gate_ = nullptr;
}

absl::StatusOr<PlanningGate::Ticket> PlanningGate::Enter(absl::Time deadline,
                                                         const std::function<bool()>& cancelled) {
  absl::MutexLock lock(&mu_);
  if (running_ < threads_) {
    ++running_;
    return Ticket(this);
  }
  if (waiting_ >= queue_) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "planner busy: ", running_, " plans running and ", waiting_, " waiting; retry later"));
  }
  ++waiting_;
  auto free = [this]() ABSL_SHARED_LOCKS_REQUIRED(mu_) { return running_ < threads_; };
  // Woken every 50 ms to ask whether the caller gave up.
  bool admitted = false;
  while (!admitted) {
    const absl::Time until = std::min(deadline, absl::Now() + absl::Milliseconds(50));
    admitted = mu_.AwaitWithDeadline(absl::Condition(&free), until);
    if (admitted) break;
    if (cancelled && cancelled()) {
      --waiting_;
      return absl::CancelledError("cancelled by the caller while waiting for a planner");
    }
    if (absl::Now() >= deadline) break;
  }
  --waiting_;
  if (!admitted) return absl::DeadlineExceededError("deadline passed while waiting for a planner");
  ++running_;
  return Ticket(this);
}

void PlanningGate::Leave() {
  absl::MutexLock lock(&mu_);
  --running_;
}

int PlanningGate::running() const {
  absl::MutexLock lock(&mu_);
  return running_;
}

}  // namespace oaipp::server
