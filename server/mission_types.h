// What a mission's calls take and give besides the core's types: its
// summary (Mission::Snapshot), the writers that make its changes durable
// before they are applied, and a plan call's settings.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/time/time.h"
#include "api/mission_config.h"
#include "core/environment/obstacle.h"
#include "core/planning/planner.h"
#include "server/idempotency_memo.h"

namespace oaipp::server {

struct MissionSnapshot {
  std::string id;
  api::MissionConfig config;
  std::vector<Obstacle> obstacles;
  double trace = 0.0;
  std::int64_t measurements_fused = 0;
  // The measurements `trace` includes (fewer than measurements_fused while
  // a sparse map's variances are computed).
  std::int64_t trace_measurements_fused = 0;
  std::int64_t paths_planned = 0;
  double mission_time_s = 0.0;
  std::int64_t memory_bytes = 0;
  absl::Time create_time;
  std::vector<std::string> removed_uav_ids;  // taken out of the team, in order
  std::vector<std::string> landed_uav_ids;   // of those, the ones that landed
};

// Writes the record of a change to durable storage, given its sequence
// number in the mission's log, before the change is applied; an error stops
// the change (nothing is applied) and is returned to the caller. `answer`
// is the change's answer when it is known before the change is applied and
// a replay could not compute it again (a measurement of a sparse map, whose
// trace comes from a background refresh): stored with the record, so that a
// retry after the mission was read back gets the first answer. Else nullptr.
using PersistFn =
    std::function<absl::Status(std::int64_t sequence, const MeasurementResult* answer)>;
// The same for a plan, written before it is answered, with the planner's
// state after it (Planner::SaveState).
using PersistPlanFn = std::function<absl::Status(std::int64_t sequence, const PlannedPath& path,
                                                 const std::string& planner_state)>;

// How Mission::Plan runs one plan (its doc says what each does).
struct MissionPlanCall {
  absl::Time deadline = absl::InfiniteFuture();
  absl::Duration budget = absl::InfiniteDuration();
  std::function<bool()> cancelled = nullptr;
  PersistPlanFn persist = nullptr;
  // PlanningContext::search_fraction: below 1 when the server sheds load.
  double search_fraction = 1.0;
  // Whether `budget` is the server's plan latency bound rather than the
  // caller's planning_budget_s (which error a plan without a path gets).
  bool budget_is_servers = false;
  // From the call's arrival until a planner took it up
  // (PlannerStats::queued_s).
  absl::Duration queued = absl::ZeroDuration();
  // The UAV to plan for (MissionConfig::CheckUavId): "" without a team.
  // With a team its path keeps PairDistance from every teammate's
  // timeline (TeamTimelines), counts their shots still to come as taken,
  // and joins its own timeline from its start (PlannedPath::team
  // stamped); FailedPrecondition for a start before the plan it already
  // holds or more than TeamTimelines::kMaxLag_s behind the mission.
  std::string uav_id = {};
};

}  // namespace oaipp::server
