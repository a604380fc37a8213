// What one MissionService allows: its streams, plans and quotas, the
// overload rules (shedding, the latency bound, take-off pacing) and the
// replica name it answers with. Read by the service and its admission
// (server/admission.h).
#pragma once

#include <string>

#include "absl/time/time.h"
#include "server/clock.h"

namespace oaipp::server {

struct ServiceLimits {
  // Open WatchMission streams in all, and per client (per tenant with
  // tokens; per connection without). Valid: >= 1.
  int max_streams = 256;
  int max_streams_per_client = 16;
  // Plans one tenant may have queued or running at once; 0: only the
  // planning pool's queue applies.
  int max_plans_per_tenant = 0;
  // The longest one plan may hold a planner: a plan without a
  // planning_budget_s, or with a longer one, gets this budget (and returns
  // the best path found by then). Valid: > 0.
  absl::Duration max_planning = absl::Seconds(60);
  // Overload: when more than shed_above x (planning threads) plans wait, a
  // plan that starts runs only that share of its search
  // (PlanningContext::search_fraction = shed_above x threads / waiting, at
  // least min_search_fraction), so the queue drains faster and waiting
  // callers get a path sooner; the response's stats.search_fraction says so.
  // 0: never shed (every plan runs its whole search).
  double shed_above = 0.0;
  double min_search_fraction = 0.1;
  // Overload: a plan that waited at least this long for a planner runs
  // min_search_fraction of its search whatever the queue behind it, so
  // that the last plans of a burst (a fleet taking off together) answer as
  // fast as its first ones instead of searching in full once the queue has
  // drained. Zero: the queue rule alone.
  absl::Duration shed_after_wait = absl::ZeroDuration();
  // Overload: a plan's search ends at most this long after its call
  // arrived, the wait for a planner included, so a burst of plans cannot
  // keep callers waiting for seconds. Plans queued together share the time
  // left until the newest one's bound: one that starts with k plans queued
  // behind it searches at most threads x (time left) / (k + 1), so the
  // queue is answered at about the bound instead of the first plans taking
  // all of it and the last ones none (plans already running on other
  // threads are not counted). A plan with (almost) nothing left still plans
  // for a hundredth of the bound and returns its best path by then
  // (stop_reason "deadline"; UNAVAILABLE if it found none, since only a
  // retry helps); stats.queued_s says how long it waited. Zero: no bound.
  // shed_above is then best left at 0: the bound already shrinks searches
  // as much as the queue needs, and no more.
  absl::Duration plan_latency = absl::ZeroDuration();
  // Take-off pacing: at most this many take-off plans (asked for at mission
  // time 0 from rest, by a UAV that has not flown yet and can wait on the
  // ground) queued or running at once, and none admitted while as many
  // plans wait as there are planning threads (UAVs in the air hover while
  // they wait). Another is refused at once with RESOURCE_EXHAUSTED and a
  // retry delay (trailing metadata api::kRetryAfterHeader): the refused
  // callers are told to come back one after another, a take-off plan's
  // recent planning time over the threads apart. A fleet that takes off
  // together then leaves over several seconds with whole first plans,
  // instead of every first plan searching a share of the bound. Replans
  // are never paced, but a repeated take-off request (same request_id) is
  // paced like a new one before its stored answer is looked up. 0: no
  // pacing.
  int max_take_off_plans = 0;
  // Take-off pacing's patience: a UAV whose first take-off request was
  // refused this long ago is no longer held back by the queue rule (as
  // many plans waiting as threads; the max_take_off_plans limit still
  // holds), so that under a steady replan load the last of a fleet do not
  // stay on the ground indefinitely. InfiniteDuration: the rule always
  // holds.
  absl::Duration take_off_patience = absl::Seconds(5);
  // Sent back on every call as the initial-metadata header
  // api::kReplicaHeader (which server answered: for operators and tests of
  // a cluster); empty: not sent.
  std::string replica_id = {};
  // What elapsed time is read from for pacing, patience and the latency
  // bound's shares (server/clock.h); must outlive the service.
  const Clock* clock = Clock::Real();
};

}  // namespace oaipp::server
