// Admission to planning: a bounded pool, so that one heavy mission cannot
// starve the others and overload is refused instead of queued without bound.
// Admission is a scoped ticket: the slot is given back when the ticket goes
// out of scope, however the plan ends (a result, an error or an exception).
//
//   PlanningGate gate(/*threads=*/2, /*queue=*/8);
//   OAIPP_ASSIGN_OR_RETURN(PlanningGate::Ticket ticket, gate.Enter(deadline));
//   ... plan ...   // the slot is released when `ticket` is destroyed
#pragma once

#include <functional>

#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"

namespace oaipp::server {

// Planning admission: at most `threads` plans run at once and at most
// `queue` wait; beyond that callers are refused, not queued.
class PlanningGate {
 public:
  // One admitted plan's slot; move-only, released on destruction.
  class Ticket {
   public:
    Ticket(Ticket&& other) noexcept : gate_(other.gate_) { other.gate_ = nullptr; }
    Ticket& operator=(Ticket&& other) noexcept;
    Ticket(const Ticket&) = delete;
    Ticket& operator=(const Ticket&) = delete;
    ~Ticket() { Release(); }

   private:
    friend class PlanningGate;
    explicit Ticket(PlanningGate* gate) : gate_(gate) {}
    void Release();
    PlanningGate* gate_;
  };

  PlanningGate(int threads, int queue) : threads_(threads), queue_(queue) {}
  PlanningGate(const PlanningGate&) = delete;
  PlanningGate& operator=(const PlanningGate&) = delete;

  // A ticket when admitted; ResourceExhausted when the queue is full;
  // DeadlineExceeded when `deadline` passes while waiting; Cancelled when
  // `cancelled` (asked every 50 ms while waiting) says the caller gave up.
  [[nodiscard]] absl::StatusOr<Ticket> Enter(absl::Time deadline,
                                             const std::function<bool()>& cancelled = nullptr);
  [[nodiscard]] int running() const;

 private:
  void Leave();

  mutable absl::Mutex mu_;
  int running_ ABSL_GUARDED_BY(mu_) = 0;
  int waiting_ ABSL_GUARDED_BY(mu_) = 0;
  const int threads_;
  const int queue_;
};

}  // namespace oaipp::server
