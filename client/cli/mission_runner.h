// Flies one scenario against the server: create the mission, then plan, fly
// the path in simulated time, let the camera fire at the planned shots,
// send what the detector saw, replan at the path's end (or, with the
// scenario's replan_on_detection, right after a shot with any report, from
// the moving state there), until the flight budget is spent (planning time
// is reported apart from flight time).
//
//   OAIPP_ASSIGN_OR_RETURN(RunResult r, RunScenario(client, scenario, sim, print_progress));
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/client.h"
#include "sim/simulation.h"

namespace oaipp::client {

// The metrics after one measurement (or at the start).
struct StepRecord {
  double mission_time_s = 0.0;
  double rse = 0.0;
  double rmse = 0.0;
  double trace = 0.0;
  int targets_found = 0;
  double path_length_m = 0.0;
  int collisions = 0;  // samples closer than r_uav / 2 (exact geometry); must stay 0
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

struct RunResult {
  std::string mission_name;
  std::vector<StepRecord> steps;
  std::vector<Vec3> flown_path_W;  // 10 Hz
  int plans = 0;
  int paths_cut = 0;  // ended at a shot with a report (replan_on_detection)
  double planning_time_s = 0.0;
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
// per step.
[[nodiscard]] std::string StepsCsv(const std::vector<StepRecord>& steps);

}  // namespace oaipp::client
