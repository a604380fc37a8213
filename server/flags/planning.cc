// oaipp-server's flags: planning, and what overload does to it.
// Defaults are ServerOptions' (server/server_options.h); ServerOptionsFromFlags
// (server/flags/flags.h) reads them.
#include <cstdint>
#include <string>

#include "absl/flags/flag.h"
#include "server/flags/flags.h"

ABSL_FLAG(int, planning_threads, oaipp::server::kFlagDefaults.planning_threads,
          "plans that may run at once");
ABSL_FLAG(int, planning_queue, oaipp::server::kFlagDefaults.planning_queue,
          "plans that may wait; more are refused (RESOURCE_EXHAUSTED)");
ABSL_FLAG(int, planning_nice, oaipp::server::kFlagDefaults.planning_nice,
          "scheduling priority of the planning threads below the rest of the server (as nice(1), "
          "0..19): when the cores are full, measurements and new missions are answered before "
          "plans; 0 gives plans the same priority");
ABSL_FLAG(double, max_planning_s, oaipp::server::kFlagDefaults.max_planning_s,
          "longest one plan may run; a plan asking for more (or no planning_budget_s) returns "
          "the best path found by then");
ABSL_FLAG(int, max_plans_per_tenant, oaipp::server::kFlagDefaults.max_plans_per_tenant,
          "plans one tenant may have queued or running; 0: no quota");
ABSL_FLAG(double, shed_above, oaipp::server::kFlagDefaults.shed_above,
          "overload: when more than this many plans per planning thread wait, a starting plan "
          "runs only (shed_above x planning_threads / waiting) of its search, at least "
          "--min_search_fraction (stats.search_fraction says so); 0: never shed");
ABSL_FLAG(double, min_search_fraction, oaipp::server::kFlagDefaults.min_search_fraction,
          "the least share of its search a shed plan runs");
ABSL_FLAG(double, shed_after_wait_s, oaipp::server::kFlagDefaults.shed_after_wait_s,
          "overload: a plan that waited this many seconds for a planner runs "
          "--min_search_fraction of its search, so the last plans of a burst answer as fast as "
          "its first; 0: only --shed_above's queue rule");
ABSL_FLAG(double, plan_latency_s, oaipp::server::kFlagDefaults.plan_latency_s,
          "overload: a plan's search ends this many seconds after its call arrived, the wait "
          "for a planner included; plans queued together share the time until the newest "
          "one's bound; none searches less than a hundredth of it (it then returns its best "
          "path so far; stats.queued_s says how long it waited); 0: no bound. With a bound, "
          "--shed_above=0 is the better setting");
ABSL_FLAG(int, max_take_off_plans, oaipp::server::kFlagDefaults.max_take_off_plans,
          "take-off pacing: take-off plans (mission time 0, at rest) queued or running at once, "
          "none admitted while as many plans wait as there are planning threads; another is "
          "refused with RESOURCE_EXHAUSTED and a retry delay in the trailing metadata "
          "x-oaipp-retry-after-ms, so a fleet taking off together leaves over several seconds "
          "with whole first plans; 0: no pacing");
ABSL_FLAG(double, take_off_patience_s, oaipp::server::kFlagDefaults.take_off_patience_s,
          "take-off pacing: a UAV whose first take-off request was refused this many seconds "
          "ago is no longer held back by the queue rule (as many plans waiting as planning "
          "threads; --max_take_off_plans still holds), so that a steady replan load cannot keep "
          "the last of a fleet on the ground; "
          ">= 0, 0: the queue rule holds only the first request");
ABSL_FLAG(std::string, dense_backend, oaipp::server::kFlagDefaults.dense_backend,
          "where the Kalman update's rank-m product runs: openblas (Debian's libopenblas0-pthread, "
          "loaded at start; Eigen when it is missing or another build) or eigen");
ABSL_FLAG(std::string, objective_precision, oaipp::server::kFlagDefaults.objective_precision,
          "the adaptive objective's solves: single (OpenBLAS's kernels about twice as fast; "
          "0.76-0.88 of double's CPU for 100 missions; a plan may differ from double's where two "
          "candidates tie, docs/capacity.md) or double");
