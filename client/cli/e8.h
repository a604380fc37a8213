// E8, the SAREnv benchmark flown through the service (docs/experiments.md):
// OA-IPP plans every path with PlanPath on a mission whose field is a
// dataset's crop (its 30 m cells, the lost-person map as the prior in
// probability units), the simulated camera feeds the map, and the flown
// paths are scored by the benchmark's evaluator (client/sarenv/metrics.h)
// beside its five baselines, on the same victims.
//
//   OAIPP_ASSIGN_OR_RETURN(v1::Scenario s, E8Scenario(area, /*agents=*/2, 100000, {}));
//   OAIPP_ASSIGN_OR_RETURN(sim::Simulation sim, sim::Simulation::Create(s));
//   OAIPP_ASSIGN_OR_RETURN(RunResult run, RunScenario(client, s, sim));
//   std::vector<sarenv::Polyline> paths = FlownPathsInCrs(run, area);
//   OAIPP_ASSIGN_OR_RETURN(sarenv::PathMetrics m,
//       sarenv::EvaluatePaths(area, sarenv::CutToBudget(paths, 20000), victims));
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/cli/mission_runner.h"
#include "client/sarenv/dataset.h"
#include "client/sarenv/metrics.h"
#include "sim/scenario.h"

namespace oaipp::client {

// How E8 flies a dataset. The camera and altitude are the benchmark's; the
// rest is this project's choice (docs/experiments.md says why each).
struct E8Settings {
  double altitude_m = 80.0;  // the benchmark's sensor altitude
  // The camera's field of view, both axes. At 45 deg its square footprint
  // (66 m) holds the benchmark's 33 m disc and its corners: the planner
  // counts a corner cell as seen where the benchmark does not.
  double fov_deg = 45.0;
  double max_speed_m_s = 15.0;
  double max_accel_m_s2 = 3.0;
  // Metres between shots at full speed (the camera's rate is speed / this):
  // a little less than the 66 m footprint, so that shots in a line overlap.
  double shot_spacing_m = 60.0;
  // The GP's length scale: well under a cell, so that a shot that saw
  // nobody lowers the cells it saw and hardly their neighbours.
  double length_scale_m = 9.0;
  int num_waypoints = 3;  // PlannerSpec.num_waypoints
  // The benchmark's discount per metre; the planner discounts each shot by
  // it to the power shot_spacing_m (PlannerSpec.detection_discount).
  double discount_per_m = 0.999;
  double team_spacing_m = 10.0;  // between the team's starts, on a line through the centre
  uint32_t seed = 1;             // the planner's
};

// The scenario that flies `area` with `agents` UAVs (1..16) until each has
// flown 2 % more than budget_m / agents (Scenario.path_budget_m; scoring
// cuts the path to the share). The world frame is the
// area's CRS shifted so that the disc's centre is the origin; every UAV
// starts there at rest at altitude_m (a team spread team_spacing_m apart
// along x). No one stands in the field: the map learns only where the
// person is not, which is what a search does until it finds them.
// InvalidArgument for an area that is not a square grid of square cells,
// or for settings out of the ranges checked here (the mission's own limits
// are the server's: sim::Simulation::Create checks them as it will).
[[nodiscard]] absl::StatusOr<v1::Scenario> E8Scenario(const sarenv::SearchArea& area, int agents,
                                                      double budget_m, const E8Settings& settings);

// Each UAV's flown path (RunResult::uavs, team order) as a 2-D polyline in
// the area's CRS metres.
[[nodiscard]] std::vector<sarenv::Polyline> FlownPathsInCrs(const RunResult& run,
                                                            const sarenv::SearchArea& area);

// One scored set of paths.
struct E8Row {
  std::string dataset;
  std::string algorithm;  // "OA-IPP" or a baseline's name
  int agents = 0;
  double budget_m = 0.0;
  sarenv::PathMetrics metrics;
  int plans = 0;               // OA-IPP: PlanPath calls of the whole flight
  double planning_s = 0.0;     // their summed latency
  double flight_wall_s = 0.0;  // wall time of the whole flight
  // OA-IPP: a UAV's path ended shorter than budget_m / agents (the time
  // budget ran out first); it is scored as flown.
  bool short_of_budget = false;
};

// "dataset,algorithm,n_agents,budget_m,likelihood,time_discounted,
// victims_found_pct,area_covered_km2,total_path_length_km,plans,planning_s,
// flight_wall_s" and a row each.
[[nodiscard]] std::string E8Csv(const std::vector<E8Row>& rows);

// Per (agents, budget): every algorithm's mean +- 1.96 SEM over its
// datasets for each score; OA-IPP minus each baseline, paired over the
// datasets both have (mean difference, its standard error, the mean in
// standard errors; n/a below two pairs or with no spread); and E8's
// targets: time-discounted above Greedy and likelihood above Spiral by
// more than 2 standard errors (a normal approximation: with 10 datasets
// Student's t would ask 2.26), victims found on average at least the best
// baseline's on the same datasets; OA-IPP flights short of their budget are
// counted.
[[nodiscard]] std::string E8SummaryMarkdown(const std::vector<E8Row>& rows);

}  // namespace oaipp::client
