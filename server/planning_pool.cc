#include "server/planning_pool.h"

#include <pthread.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace oaipp::server {

PlanningPool::PlanningPool(int threads, int queue, int nice)
    : queue_(queue), nice_(std::clamp(nice, 0, 19)) {
  threads_.reserve(static_cast<std::size_t>(threads));
  for (int i = 0; i < threads; ++i) {
    threads_.emplace_back([this] {
      // On Linux the nice value is per thread (PRIO_PROCESS with a thread
      // id); raising it is always allowed, so this cannot fail but for a
      // seccomp policy, and then the plans simply keep the process's
      // priority.
      if (nice_ > 0) {
        (void)setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()),
                          getpriority(PRIO_PROCESS, 0) + nice_);
      }
      // Named for top -H, perf and the tests that watch a plan run.
      (void)pthread_setname_np(pthread_self(), "oaipp-plan");
      Work();
    });
  }
}

PlanningPool::~PlanningPool() {
  {
    absl::MutexLock lock(&mu_);
    stopping_ = true;
  }
  for (std::thread& t : threads_) t.join();
}

absl::StatusOr<PlanningPool::Handle> PlanningPool::Submit(std::string key,
                                                          std::function<void()> job) {
  absl::MutexLock lock(&mu_);
  // A free thread takes the job at once, so it only waits when all are busy.
  const int idle = static_cast<int>(threads_.size()) - running_;
  if (waiting_ >= queue_ + std::max(0, idle)) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "planner busy: ", running_, " plans running and ", waiting_, " waiting; retry later"));
  }
  auto queued = std::make_shared<Job>();
  queued->key = std::move(key);
  queued->run = std::move(job);
  queued_.push_back(queued);
  ++waiting_;
  return Handle(this, std::move(queued));
}

bool PlanningPool::Handle::Cancel() {
  if (job_ == nullptr) return false;
  int expected = 0;
  if (!job_->state.compare_exchange_strong(expected, 2)) return false;
  absl::MutexLock lock(&pool_->mu_);
  --pool_->waiting_;
  return true;
}

void PlanningPool::Work() {
  while (true) {
    std::shared_ptr<Job> job;
    {
      absl::MutexLock lock(&mu_);
      // The first job whose mission is not planning already; cancelled jobs
      // are dropped on the way.
      auto runnable = [this]() ABSL_SHARED_LOCKS_REQUIRED(mu_) {
        for (const auto& j : queued_) {
          if (j->state.load() == 2 || !busy_keys_.contains(j->key)) return true;
        }
        return stopping_ && queued_.empty();
      };
      mu_.Await(absl::Condition(&runnable));
      for (auto it = queued_.begin(); it != queued_.end();) {
        if ((*it)->state.load() == 2) {
          it = queued_.erase(it);
          continue;
        }
        if (!busy_keys_.contains((*it)->key)) {
          int expected = 0;
          if ((*it)->state.compare_exchange_strong(expected, 1)) {
            job = *it;
            --waiting_;
            ++running_;
            busy_keys_.insert(job->key);
          }
          queued_.erase(it);
          break;
        }
        ++it;
      }
      if (job == nullptr) {
        if (stopping_ && queued_.empty()) return;
        continue;  // only cancelled jobs were dropped
      }
    }
    job->run();
    job->run = nullptr;  // what it captured goes now, not with the last handle
    absl::MutexLock lock(&mu_);
    --running_;
    busy_keys_.erase(busy_keys_.find(job->key));
  }
}

int PlanningPool::running() const {
  absl::MutexLock lock(&mu_);
  return running_;
}

int PlanningPool::waiting() const {
  absl::MutexLock lock(&mu_);
  return waiting_;
}

}  // namespace oaipp::server
