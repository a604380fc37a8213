// The planning gate's admission, and its scoped tickets: a slot comes back
// however the plan ends, an exception included.
#include "server/planning_gate.h"

#include <stdexcept>
#include <utility>

#include "absl/time/clock.h"
#include "gtest/gtest.h"

namespace oaipp::server {
namespace {

TEST(PlanningGateTest, AdmitsUpToThreadsThenQueuesThenRefuses) {
  PlanningGate gate(/*threads=*/2, /*queue=*/0);
  absl::StatusOr<PlanningGate::Ticket> a = gate.Enter(absl::InfiniteFuture());
  absl::StatusOr<PlanningGate::Ticket> b = gate.Enter(absl::InfiniteFuture());
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(gate.running(), 2);
  // No queue: the third is refused at once, not made to wait.
  EXPECT_EQ(gate.Enter(absl::InfiniteFuture()).status().code(),
            absl::StatusCode::kResourceExhausted);
}

TEST(PlanningGateTest, WaitingPastTheDeadlineIsDeadlineExceeded) {
  PlanningGate gate(/*threads=*/1, /*queue=*/1);
  absl::StatusOr<PlanningGate::Ticket> held = gate.Enter(absl::InfiniteFuture());
  ASSERT_TRUE(held.ok());
  EXPECT_EQ(gate.Enter(absl::Now() + absl::Milliseconds(20)).status().code(),
            absl::StatusCode::kDeadlineExceeded);
  EXPECT_EQ(gate.running(), 1);
}

TEST(PlanningGateTest, TicketReleasesItsSlotWhenItGoesOutOfScope) {
  PlanningGate gate(/*threads=*/1, /*queue=*/0);
  {
    absl::StatusOr<PlanningGate::Ticket> ticket = gate.Enter(absl::InfiniteFuture());
    ASSERT_TRUE(ticket.ok());
    EXPECT_EQ(gate.running(), 1);
  }
  EXPECT_EQ(gate.running(), 0);
  EXPECT_TRUE(gate.Enter(absl::InfiniteFuture()).ok());
}

TEST(PlanningGateTest, APlannerThatThrowsDoesNotLeakItsSlot) {
  PlanningGate gate(/*threads=*/1, /*queue=*/0);
  const auto plan = [&] {
    absl::StatusOr<PlanningGate::Ticket> ticket = gate.Enter(absl::InfiniteFuture());
    ASSERT_TRUE(ticket.ok());
    throw std::bad_alloc();
  };
  EXPECT_THROW(plan(), std::bad_alloc);
  EXPECT_EQ(gate.running(), 0);
  EXPECT_TRUE(gate.Enter(absl::InfiniteFuture()).ok());
}

TEST(PlanningGateTest, AMovedTicketReleasesOnce) {
  PlanningGate gate(/*threads=*/2, /*queue=*/0);
  absl::StatusOr<PlanningGate::Ticket> first = gate.Enter(absl::InfiniteFuture());
  ASSERT_TRUE(first.ok());
  {
    PlanningGate::Ticket moved = std::move(*first);
    EXPECT_EQ(gate.running(), 1);
  }
  EXPECT_EQ(gate.running(), 0);
  first = gate.Enter(absl::InfiniteFuture());  // the moved-from ticket holds nothing
  EXPECT_EQ(gate.running(), 1);
}

}  // namespace
}  // namespace oaipp::server
