// Flies one scenario against the server: create the mission, then plan, fly
// the path in simulated time, let the camera fire at the planned shots,
// send what the detector saw, replan at the path's end (or, with the
// scenario's replan_on_detection, right after a shot with any report, from
// the moving state there), until the flight budget is spent or, with the
// scenario's path_budget_m, the path is that long (planning time is
// reported apart from flight time). The map is read after every shot for
// the records, or only at the start and the end (final_map_only).
//
// A team scenario (mission.team) flies every member on the one mission
// clock: each UAV steps its own path every 20 ms of flight, the step due
// first going first (the earlier member in the spec on a tie), so the run is
// the same for the same scenario and seed. A UAV plans when its path ends,
// naming its uav_id; each has its own detector (the scenario's, seeded with
// seed + its index). A member at rest whose plan is refused because it is
// boxed in (FAILED_PRECONDITION) hovers there for 1 s and asks again. After
// every step the runner measures, with its own distance code, how close the
// UAV is to each teammate at that instant.
//
// With the scenario's separate_maps, each member flies a mission of its
// own instead (Scenario.separate_maps says what is then recorded).
//
//   OAIPP_ASSIGN_OR_RETURN(RunResult r, RunScenario(client, scenario, sim, print_progress));
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/client.h"
#include "sim/simulation.h"

namespace oaipp::client {

// The metrics after one measurement (or at the start).
struct StepRecord {
  std::string uav_id;  // whose shot it was; empty at the start and without a team
  double mission_time_s = 0.0;
  double rse = 0.0;
  double rmse = 0.0;
  double trace = 0.0;
  int targets_found = 0;
  double path_length_m = 0.0;  // the team's, summed
  int collisions = 0;  // samples closer than r_uav / 2 (exact geometry), the team's; must stay 0
};

// One time a target was in view (sim::TargetSightings counts them): when,
// from how high, whether the detector reported it, and the highest map mean
// on its cells once that shot was fused (Simulation::TargetMeans): how a
// person came to be found, or to be cleared by later misses.
struct SightingRecord {
  int target = 0;  // index in the scenario's order
  double mission_time_s = 0.0;
  double altitude_m = 0.0;
  bool detected = false;
  double mean_after = 0.0;
};

// One UAV's flight.
struct UavRecord {
  std::string uav_id;              // empty without a team
  std::string mission;             // the mission it flew in (its own with separate maps)
  std::vector<Vec3> flown_path_W;  // a point every sim::Flight::kTraceSpacing_m
  int plans = 0;
  int paths_cut = 0;  // ended at a shot with a report (replan_on_detection)
  int holds = 0;      // plans refused while boxed in at rest (team), each a 1 s hover
  int shots = 0;
  double path_length_m = 0.0;
  int collisions = 0;
  // With spec.home: set once it has flown the way home (then it is done),
  // to the flight seconds the server said would be left once landed.
  std::optional<double> landed_with_s;
};

struct RunResult {
  std::string mission_name;
  std::vector<StepRecord> steps;
  std::vector<UavRecord> uavs;  // in the spec's team order; one without a team
  int plans = 0;                // the team's
  int paths_cut = 0;
  int holds = 0;
  double planning_time_s = 0.0;
  std::vector<double> plan_latencies_s;  // each PlanPath call's, as the client saw it
  // The least distance between two UAVs at one instant, over every step of
  // each (infinity for one UAV), and the steps at which two were closer
  // than the spec's min_separation_m.
  double closest_approach_m = 0.0;
  double min_separation_m = 0.0;
  int separation_violations = 0;
  std::string final_map_png;       // map mean | std with obstacles, targets and the flown path
  std::vector<bool> found_at_end;  // per target, Simulation::FoundEach of the final map
  std::vector<sim::TargetSightings> sightings;  // per target, over the whole flight
  std::vector<SightingRecord> sighting_log;     // in flight order
};

// progress: called with the metrics after each measurement. frame: when
// set, called with a PNG of the map (as final_map_png, path flown so far)
// at the start and after each measurement: an image sequence of the mission.
[[nodiscard]] absl::StatusOr<RunResult> RunScenario(
    Client& client, const v1::Scenario& scenario, const sim::Simulation& simulation,
    const std::function<void(const StepRecord&)>& progress = nullptr, bool keep_mission = false,
    const std::function<void(const std::string& png)>& frame = nullptr);

// "time_s,rse,rmse,trace,targets_found,path_length_m,collisions" and a row
// per step; with a team, a first column uav_id.
[[nodiscard]] std::string StepsCsv(const std::vector<StepRecord>& steps);

}  // namespace oaipp::client
