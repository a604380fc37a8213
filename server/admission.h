// Who may start what on a MissionService, now: the stream and plan quotas,
// the overload rules a starting plan follows (how much of its search it
// runs, how long it may search under the latency bound), and take-off
// pacing. The service asks before it opens a stream or queues a plan and
// says when one ends; health reads Overloaded().
#pragma once

#include <map>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "server/planning_pool.h"
#include "server/service_limits.h"

namespace oaipp::server {

class Admission {
 public:
  // `planners` must outlive this; its queue is read, never changed.
  Admission(const ServiceLimits& limits, const PlanningPool* planners)
      : limits_(limits), planners_(planners) {}

  // Stream and plan quotas: Acquire* refuses with ResourceExhausted.
  absl::Status AcquireStream(const std::string& client);
  void ReleaseStream(const std::string& client);
  absl::Status AcquirePlan(const std::string& tenant);
  void ReleasePlan(const std::string& tenant);

  // True while new plans or streams would be refused: every planner busy
  // and the queue full, or the stream limit reached (health reports it).
  [[nodiscard]] bool Overloaded() const;
  // The share of its search a plan starting now, after waiting `queued`
  // for a planner, runs (ServiceLimits::shed_above, shed_after_wait).
  [[nodiscard]] double SearchFraction(absl::Duration queued) const;
  // With a plan latency bound: how long a plan starting now may search so
  // that it and the plans queued behind it all end by the newest one's
  // bound (ServiceLimits::plan_latency).
  [[nodiscard]] absl::Duration FairShare() const;
  // A plan that arrived at `arrived` was queued (FairShare's newest plan).
  void NotePlanQueued(absl::Time arrived);
  // Take-off pacing (ServiceLimits::max_take_off_plans): nullopt, and the
  // plan is counted, when a take-off plan may be queued now; else how long
  // its caller should wait before asking again (at most kMaxTakeOffDelay)
  // and why.
  struct TakeOffRefusal {
    absl::Duration retry_after;
    std::string reason;
  };
  static constexpr absl::Duration kMaxTakeOffDelay = absl::Seconds(10);
  // `grounded_since`: when the asking mission's take-off was first refused
  // (nullopt: it was not).
  [[nodiscard]] std::optional<TakeOffRefusal> AdmitTakeOff(
      std::optional<absl::Time> grounded_since);
  // A take-off plan admitted by AdmitTakeOff ended, after planning for
  // `planned` (zero when it did not run).
  void TakeOffEnded(absl::Duration planned);
  [[nodiscard]] int open_streams() const;

 private:
  const ServiceLimits limits_;
  const PlanningPool* const planners_;

  mutable absl::Mutex quota_mu_;
  int streams_ ABSL_GUARDED_BY(quota_mu_) = 0;
  std::map<std::string, int> streams_by_client_ ABSL_GUARDED_BY(quota_mu_);
  std::map<std::string, int> plans_by_tenant_ ABSL_GUARDED_BY(quota_mu_);
  // When the newest queued plan arrived (NotePlanQueued).
  absl::Time newest_plan_ ABSL_GUARDED_BY(quota_mu_) = absl::InfinitePast();
  // Take-off pacing: admitted take-off plans not yet ended, the time the
  // last refused caller was told to come back, and the running mean of a
  // take-off plan's planning time (0.1 s until one has run).
  int take_offs_ ABSL_GUARDED_BY(quota_mu_) = 0;
  absl::Time take_off_slot_ ABSL_GUARDED_BY(quota_mu_) = absl::InfinitePast();
  absl::Duration take_off_cost_ ABSL_GUARDED_BY(quota_mu_) = absl::Milliseconds(100);
};

}  // namespace oaipp::server
