// The planning pool: bounded admission, jobs of one mission in order, and a
// queued job taken back out without ever running, and plans at a lower
// scheduling priority than the thread that submits them.
#include "server/planning_pool.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <memory>
#include <vector>

#include "absl/synchronization/notification.h"
#include "absl/time/clock.h"
#include "gtest/gtest.h"

namespace oaipp::server {
namespace {

// Submits a job of mission `key` that holds its planner until `release` is
// notified, and waits until it runs (unless the pool refused it).
absl::StatusOr<PlanningPool::Handle> HoldAPlanner(PlanningPool& pool, const std::string& key,
                                                  absl::Notification& release) {
  auto started = std::make_shared<absl::Notification>();
  absl::StatusOr<PlanningPool::Handle> job = pool.Submit(key, [started, &release] {
    started->Notify();
    release.WaitForNotification();
  });
  if (job.ok()) started->WaitForNotification();
  return job;
}

TEST(PlanningPoolTest, RunsUpToThreadsPlusQueueThenRefuses) {
  PlanningPool pool(/*threads=*/1, /*queue=*/1);
  absl::Notification release;
  ASSERT_TRUE(HoldAPlanner(pool, "a", release).ok());
  EXPECT_EQ(pool.running(), 1);
  std::atomic<int> ran{0};
  ASSERT_TRUE(pool.Submit("b", [&] { ++ran; }).ok());
  EXPECT_EQ(pool.waiting(), 1);
  const absl::StatusOr<PlanningPool::Handle> refused = pool.Submit("c", [&] { ++ran; });
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kResourceExhausted);
  release.Notify();
  while (pool.running() + pool.waiting() > 0) absl::SleepFor(absl::Milliseconds(1));
  EXPECT_EQ(ran.load(), 1);
}

TEST(PlanningPoolTest, ACancelledJobNeverRunsAndFreesItsPlaceAtOnce) {
  PlanningPool pool(/*threads=*/1, /*queue=*/1);
  absl::Notification release;
  ASSERT_TRUE(HoldAPlanner(pool, "a", release).ok());
  bool ran = false;
  absl::StatusOr<PlanningPool::Handle> queued = pool.Submit("b", [&] { ran = true; });
  ASSERT_TRUE(queued.ok());
  EXPECT_TRUE(queued->Cancel());
  EXPECT_FALSE(queued->Cancel());  // once
  EXPECT_EQ(pool.waiting(), 0);
  EXPECT_TRUE(pool.Submit("c", [] {}).ok());  // the place is free again
  release.Notify();
  while (pool.running() + pool.waiting() > 0) absl::SleepFor(absl::Milliseconds(1));
  EXPECT_FALSE(ran);
}

TEST(PlanningPoolTest, AStartedJobCannotBeCancelled) {
  PlanningPool pool(/*threads=*/1, /*queue=*/0);
  absl::Notification release;
  absl::StatusOr<PlanningPool::Handle> job = HoldAPlanner(pool, "a", release);
  ASSERT_TRUE(job.ok());
  EXPECT_FALSE(job->Cancel());
  release.Notify();
}

TEST(PlanningPoolTest, OneMissionsJobsRunInOrderAndLetOthersPass) {
  // Two threads; mission "a" submits three jobs, then "b" one. "a"'s jobs
  // must not take both threads: "b" runs beside "a"'s first.
  PlanningPool pool(/*threads=*/2, /*queue=*/8);
  absl::Mutex mu;
  std::vector<std::string> order;
  absl::Notification a_first_may_end;
  absl::Notification b_ran;
  auto record = [&](const std::string& what) {
    absl::MutexLock lock(&mu);
    order.push_back(what);
  };
  ASSERT_TRUE(pool.Submit("a",
                          [&] {
                            record("a1");
                            a_first_may_end.WaitForNotification();
                          })
                  .ok());
  ASSERT_TRUE(pool.Submit("a", [&] { record("a2"); }).ok());
  ASSERT_TRUE(pool.Submit("a", [&] { record("a3"); }).ok());
  ASSERT_TRUE(pool.Submit("b",
                          [&] {
                            record("b1");
                            b_ran.Notify();
                          })
                  .ok());
  // "b" runs while "a1" still holds its thread.
  b_ran.WaitForNotification();
  a_first_may_end.Notify();
  while (pool.running() + pool.waiting() > 0) absl::SleepFor(absl::Milliseconds(1));
  absl::MutexLock lock(&mu);
  ASSERT_EQ(order.size(), 4u);
  std::vector<std::string> a_only;
  for (const auto& o : order) {
    if (o[0] == 'a') a_only.push_back(o);
  }
  EXPECT_EQ(a_only, (std::vector<std::string>{"a1", "a2", "a3"}));
  // a2 could start only after a1 ended, which waited for b1.
  EXPECT_LT(std::find(order.begin(), order.end(), "b1") - order.begin(),
            std::find(order.begin(), order.end(), "a2") - order.begin());
}

// The nice value is read by the kernel for the thread that runs the job
// (getpriority with its thread id), not taken from the pool.
TEST(PlanningPoolTest, JobsRunAtTheGivenNiceAboveTheSubmittingThread) {
  const int own = getpriority(PRIO_PROCESS, static_cast<id_t>(gettid()));
  for (const int nice : {0, 7}) {
    PlanningPool pool(/*threads=*/2, /*queue=*/4, nice);
    std::atomic<int> seen[2] = {-100, -100};
    for (int i = 0; i < 2; ++i) {
      ASSERT_TRUE(pool.Submit(std::to_string(i),
                              [&seen, i] {
                                seen[i] = getpriority(PRIO_PROCESS, static_cast<id_t>(gettid()));
                              })
                      .ok());
    }
    while (pool.running() + pool.waiting() > 0 || seen[0] == -100 || seen[1] == -100) {
      absl::SleepFor(absl::Milliseconds(1));
    }
    EXPECT_EQ(seen[0].load(), std::min(own + nice, 19)) << "nice " << nice;
    EXPECT_EQ(seen[1].load(), std::min(own + nice, 19)) << "nice " << nice;
  }
  // The submitting thread keeps its own priority.
  EXPECT_EQ(getpriority(PRIO_PROCESS, static_cast<id_t>(gettid())), own);
  EXPECT_EQ(PlanningPool(1, 1, 40).nice(), 19);
  EXPECT_EQ(PlanningPool(1, 1, -3).nice(), 0);
}

}  // namespace
}  // namespace oaipp::server
