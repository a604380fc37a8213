// The threads that run plans, and admission to them: at most `threads`
// plans run at once, at most `queue` wait, and beyond that a plan is refused
// (RESOURCE_EXHAUSTED) instead of queued without bound. A waiting plan is a
// queued job, not a blocked thread, so plans waiting for a slot cost the
// server nothing but their request.
//
// Jobs with the same key (a mission) run one after another in submission
// order, so a mission queues behind its own previous plan, never in front of
// other missions' plans.
//
//   PlanningPool pool(/*threads=*/2, /*queue=*/16);
//   OAIPP_ASSIGN_OR_RETURN(PlanningPool::Handle job, pool.Submit("m1", [] { ... }));
//   ...
//   if (job.Cancel()) { /* taken out of the queue: it will never run */ }
#pragma once

#include <atomic>
#include <deque>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"

namespace oaipp::server {

class PlanningPool {
 private:
  struct Job;

 public:
  // A submitted job, to take it back out of the queue.
  class Handle {
   public:
    Handle() = default;
    // True when the job had not started and never will (it is dropped, and
    // its queue place is free at once); false once it started.
    bool Cancel();

   private:
    friend class PlanningPool;
    Handle(PlanningPool* pool, std::shared_ptr<Job> job) : pool_(pool), job_(std::move(job)) {}
    PlanningPool* pool_ = nullptr;
    std::shared_ptr<Job> job_;
  };

  PlanningPool(int threads, int queue);
  // Runs the jobs already started to the end; queued jobs are run too.
  ~PlanningPool();
  PlanningPool(const PlanningPool&) = delete;
  PlanningPool& operator=(const PlanningPool&) = delete;

  // Queues `job`; ResourceExhausted when `queue` jobs are already waiting.
  // The job must not throw.
  [[nodiscard]] absl::StatusOr<Handle> Submit(std::string key, std::function<void()> job);

  [[nodiscard]] int running() const;
  [[nodiscard]] int waiting() const;
  [[nodiscard]] int threads() const { return static_cast<int>(threads_.size()); }
  [[nodiscard]] int queue_capacity() const { return queue_; }

 private:
  struct Job {
    std::string key;
    std::function<void()> run;
    // 0 queued, 1 started, 2 cancelled.
    std::atomic<int> state{0};
  };
  void Work();

  mutable absl::Mutex mu_;
  std::deque<std::shared_ptr<Job>> queued_ ABSL_GUARDED_BY(mu_);
  std::multiset<std::string> busy_keys_ ABSL_GUARDED_BY(mu_);
  int waiting_ ABSL_GUARDED_BY(mu_) = 0;
  int running_ ABSL_GUARDED_BY(mu_) = 0;
  bool stopping_ ABSL_GUARDED_BY(mu_) = false;
  const int queue_;
  std::vector<std::thread> threads_;
};

}  // namespace oaipp::server
