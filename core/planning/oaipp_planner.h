// OA-IPP: greedy start + CMA-ES refinement over minimum-snap paths
// (docs/method.md §7; Anil Meera et al., ICRA 2019, Algorithms 1 and 2).
//
// 1. Greedy start: for each of the N - 1 free waypoints, candidate
//    viewpoints are drawn on several altitude layers; those reachable in a
//    straight collision-free line from the previous waypoint are scored by
//    the objective of a measurement taken there over the time to fly there;
//    the best is kept and its predicted measurement conditions the next.
//    Past the deadline it stops with the waypoints it has.
// 2. CMA-ES over the 3 (N - 1) coordinates inside the flight volume, started
//    at the greedy path with steps of a few metres, until the evaluation
//    budget or the deadline (anytime: the best path so far is kept).
// 3. The best candidates without ESDF collisions are checked exactly, best
//    first; the first that passes is returned.
//
// Plans are a pure function of (mission, state, config): the random streams
// are seeded from config.seed and the state's mission time.
//
//   OaIppPlanner planner(PlannerCommon{.seed = 7}, OaIppConfig{});
//   OAIPP_ASSIGN_OR_RETURN(PlannedPath path, planner.Plan(view, state, deadline));
#pragma once

#include <cstdint>
#include <vector>

#include "core/planning/path_scorer.h"
#include "core/planning/planner.h"

namespace oaipp {

struct OaIppConfig {
  // Control waypoints N, the UAV's position included (paper code: 3).
  // Valid: 2 .. 20.
  int num_waypoints = 3;
  // Greedy candidate layers (metres above ground) and candidates per layer.
  std::vector<double> greedy_altitudes_m = {4.0, 8.0, 12.0, 16.0, 20.0};
  int greedy_candidates_per_layer = 12;
  // CMA-ES: population lambda, generations, initial steps per waypoint
  // coordinate (x, y, z) in metres. lambda x generations = evaluation budget.
  int population = 12;
  int generations = 45;
  // Stop the search early once the best score beats the best of
  // stall_generations generations before by no more than stall_tolerance
  // times that earlier score
  // (CmaesOptions; 0: always run every generation, the paper's setting).
  int stall_generations = 0;
  double stall_tolerance = 1e-3;
  Vec3 step_m = Vec3(4.0, 4.0, 3.0);
  // When false the greedy path is returned as it is.
  bool refine = true;
  // How many of the best ESDF-collision-free candidates go to the exact check.
  int exact_check_candidates = 8;

  [[nodiscard]] absl::Status Validate() const;
};

class OaIppPlanner final : public Planner {
 public:
  OaIppPlanner(PlannerCommon common, OaIppConfig config)
      : common_(std::move(common)), config_(std::move(config)) {}
  [[nodiscard]] absl::string_view name() const override {
    return common_.information.kind == ObjectiveKind::kAdaptive ? "oaipp" : "oaipp_nonadaptive";
  }
  [[nodiscard]] absl::StatusOr<PlannedPath> Plan(const PlanningContext& mission,
                                                 const UavState& state,
                                                 absl::Time deadline) override;
  [[nodiscard]] const PlannerCommon& common() const { return common_; }
  [[nodiscard]] const OaIppConfig& config() const { return config_; }

  // The greedy start alone (exposed for tests): N - 1 waypoints, or fewer
  // when the deadline passes (it stops once the current waypoint has a
  // reachable candidate, and the path ends there).
  [[nodiscard]] std::vector<Vec3> GreedyStart(const PathScorer& scorer, std::uint64_t seed,
                                              absl::Time deadline, std::int64_t* evaluations) const;

 private:
  PlannerCommon common_;
  OaIppConfig config_;
};

// A 64-bit seed mixing a user seed with a mission time (SplitMix64), so that
// each replan of a mission draws fresh but reproducible random numbers.
[[nodiscard]] std::uint64_t MixSeed(std::uint64_t seed, double mission_time_s);

}  // namespace oaipp
