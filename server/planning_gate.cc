#include "server/planning_gate.h"

#include "absl/strings/str_cat.h"

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

absl::StatusOr<PlanningGate::Ticket> PlanningGate::Enter(absl::Time deadline) {
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
  const bool admitted = mu_.AwaitWithDeadline(absl::Condition(&free), deadline);
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
