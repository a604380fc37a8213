// The share of its search a starting plan runs: by the queue behind it
// (shed_above) and by its own wait (shed_after_wait).
#include "server/admission.h"

#include "gtest/gtest.h"
#include "server/planning_pool.h"

namespace oaipp::server {
namespace {

TEST(AdmissionTest, APlanThatWaitedPastTheLimitRunsTheLeastShare) {
  const PlanningPool pool(/*threads=*/2, /*queue=*/8, /*nice=*/0);
  const ServiceLimits limits{
      .shed_above = 2.0, .min_search_fraction = 0.15, .shed_after_wait = absl::Seconds(1)};
  const Admission admission(limits, &pool);
  // Nothing queued: the whole search, unless the plan itself waited long.
  EXPECT_EQ(admission.SearchFraction(absl::ZeroDuration()), 1.0);
  EXPECT_EQ(admission.SearchFraction(absl::Milliseconds(999)), 1.0);
  EXPECT_EQ(admission.SearchFraction(absl::Seconds(1)), 0.15);
  EXPECT_EQ(admission.SearchFraction(absl::Seconds(30)), 0.15);
}

TEST(AdmissionTest, WithoutAWaitLimitOnlyTheQueueSheds) {
  const PlanningPool pool(/*threads=*/2, /*queue=*/8, /*nice=*/0);
  const Admission admission({.shed_above = 2.0, .min_search_fraction = 0.15}, &pool);
  EXPECT_EQ(admission.SearchFraction(absl::Seconds(30)), 1.0);
}

}  // namespace
}  // namespace oaipp::server
