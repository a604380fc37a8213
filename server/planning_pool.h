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
// The threads may run at a lower scheduling priority than the rest of the
// process (`nice`, as nice(1): 0 to 19). A plan is long and may be
// shortened (overload shedding); a measurement or a new mission is short and
// the UAV waits for its answer. With plans at nice 10, Linux gives a busy
// gRPC thread about nine times a busy planner's share of a core, so the
// short calls are answered first when the cores are full, and plans get
// everything else.
//
//   PlanningPool pool(/*threads=*/2, /*queue=*/16, /*nice=*/10);
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

  // nice: 0 (the process's priority) to 19 (lowest); values outside are
  // clamped. Lowering a thread's priority needs no privilege.
  PlanningPool(int threads, int queue, int nice = 0);
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
  [[nodiscard]] int nice() const { return nice_; }

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
  const int nice_;
  std::vector<std::thread> threads_;
};

}  // namespace oaipp::server
