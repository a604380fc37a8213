// Many trials of a scenario with several planners, run as concurrent
// missions on one server (DESIGN.md §4): per-trial metrics on a common time
// grid and a summary per planner.
//
//   EvalOptions options{.trials = 25, .parallel = 2};
//   OAIPP_ASSIGN_OR_RETURN(EvalResult r, RunEvaluation(address, scenario,
//       {PlannerKind::kOaIpp, PlannerKind::kLawnmower, PlannerKind::kRandom}, options, progress));
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/mission_runner.h"
#include "core/planning/planners.h"

namespace oaipp::client {

struct EvalOptions {
  int trials = 25;               // per planner; trial k uses seed k for planner and detector
  int parallel = 2;              // missions flown at once
  double grid_s = 5.0;           // time grid of the resampled curves
  double plan_deadline_s = 0.0;  // per PlanPath call; 0: no deadline (full budget)
};

struct TrialResult {
  PlannerKind planner;
  int trial = 0;
  std::vector<StepRecord> steps;
  int plans = 0;
  double planning_time_s = 0.0;
  std::string error;  // non-empty when the trial failed
};

struct EvalResult {
  std::vector<TrialResult> trials;
  std::vector<double> grid_s;
};

// For each grid time t, the last record taken before t (the first record
// for t = 0): the map after every measurement before t.
[[nodiscard]] std::vector<StepRecord> Resample(const std::vector<StepRecord>& steps,
                                               const std::vector<double>& grid_s);

// progress(done, total) after each trial.
[[nodiscard]] absl::StatusOr<EvalResult> RunEvaluation(
    const std::string& address, const v1::Scenario& scenario,
    const std::vector<PlannerKind>& planners, const EvalOptions& options,
    const std::function<void(int, int)>& progress);

// planner,trial,time_s,rse,rmse,trace,targets_found,path_length_m,collisions
// on the grid, one row per planner, trial and grid time.
[[nodiscard]] std::string TrialsCsv(const EvalResult& result);
// A Markdown table per planner: trials, failures, RSE at the start and the
// end (mean +- std, standard error), targets found, collisions, planning
// time per plan.
[[nodiscard]] std::string SummaryMarkdown(const EvalResult& result, double budget_s);

}  // namespace oaipp::client
