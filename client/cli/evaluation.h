// Many trials of several variants (planners, or worlds), run as concurrent
// missions on one server (docs/method.md §10): per-trial metrics on a common time
// grid and a summary per variant.
//
//   EvalOptions options{.trials = 25, .parallel = 2};
//   OAIPP_ASSIGN_OR_RETURN(EvalResult r, RunEvaluation(address, PlannerVariants(scenario,
//       {PlannerKind::kOaIpp, PlannerKind::kLawnmower, PlannerKind::kRandom}), options, progress));
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/cli/mission_runner.h"
#include "core/planning/planners.h"

namespace oaipp::client {

// Largest first trial (seed) an evaluation may start from, and most trials
// per variant: their sum stays far inside an int.
inline constexpr int kMaxFirstTrial = 1'000'000;
inline constexpr int kMaxTrials = 1'000'000;

struct EvalOptions {
  int trials = 25;      // per planner; trial k uses seed k for planner and detector
  int first_trial = 1;  // trials first_trial .. first_trial + trials - 1 (>= 1)
  int parallel = 2;     // missions flown at once
  double grid_s = 5.0;  // time grid of the resampled curves
  // Wall-clock seconds per replan (sets Scenario.planning_budget_s);
  // 0: the scenario's own setting.
  double plan_budget_s = 0.0;
  // How each worker connects (token, TLS).
  ClientOptions client = {};
};

// What is compared: a label and the scenario of each trial.
struct Variant {
  std::string label;  // e.g. "oaipp", "high-rise 10"
  // The scenario of trial k (1-based) with its seeds set. An error fails
  // that trial only.
  std::function<absl::StatusOr<v1::Scenario>(int trial)> scenario;
};

// One variant per planner on `scenario`, labelled with the planner's name;
// trial k uses seed k for the planner and the detector.
[[nodiscard]] std::vector<Variant> PlannerVariants(const v1::Scenario& scenario,
                                                   const std::vector<PlannerKind>& planners);

// The confirmation settings an evaluation flies oaipp_confirm with
// (docs/method.md §6.4; each is the PlannerSpec field of the same name).
struct ConfirmationOptions {
  double weight = 0.0;  // confirmation_weight
  // The phase over the last phase_s seconds of the budget; 0: none, and
  // then the fields below are not set either.
  double phase_s = 0.0;
  // The phase's weight on undecided cells; unset: the scenario's.
  std::optional<double> phase_weight = std::nullopt;
  // The phase's margin around the threshold; unset: the scenario's.
  std::optional<double> ambiguity_margin = std::nullopt;
  // The second look and its sharpness; 0: not set (the planner's default).
  double second_look_weight = 0.0;
  double second_look_sharpness = 0.0;
};

// OA-IPP with the confirmation objective at `options`, labelled
// "oaipp_confirm"; otherwise as PlannerVariants' OA-IPP, so that trial k of
// both flies the same world, people and seeds.
[[nodiscard]] Variant ConfirmationVariant(const v1::Scenario& scenario,
                                          const ConfirmationOptions& options);

// The variants of `all` whose labels `labels` names, in the order of `all`
// (every one when `labels` is empty). InvalidArgument naming `flag` when a
// label is not among them or is named twice.
[[nodiscard]] absl::StatusOr<std::vector<Variant>> SelectVariants(
    std::vector<Variant> all, const std::vector<std::string>& labels, const std::string& flag);

struct TrialResult {
  std::string variant;
  int trial = 0;
  int num_targets = 0;
  std::vector<StepRecord> steps;
  int plans = 0;
  double planning_time_s = 0.0;
  std::string map_png;  // the final map with the flown path (the first trial only)
  std::vector<std::string> target_ids;
  std::vector<bool> found_at_end;               // per target id
  std::vector<sim::TargetSightings> sightings;  // per target id
  std::vector<SightingRecord> sighting_log;     // RunResult::sighting_log
  std::string error;                            // non-empty when the trial failed
  // Team metrics (RunResult's): how many UAVs flew, the mission time from
  // the start until every target was found at once (-1: never, within the
  // budget), the least distance between two UAVs and the steps closer than
  // the separation, and every plan's latency.
  int uavs = 1;
  double all_found_s = -1.0;
  double closest_approach_m = 0.0;
  int separation_violations = 0;
  std::vector<double> plan_latencies_s;
};

struct EvalResult {
  std::vector<TrialResult> trials;
  std::vector<double> grid_s;
};

// For each grid time t, the last record taken before t (the first record
// for t = 0): the map after every measurement before t.
[[nodiscard]] std::vector<StepRecord> Resample(const std::vector<StepRecord>& steps,
                                               const std::vector<double>& grid_s);

// progress(done, total) after each trial. The time grid spans the budget of
// the first variant's first trial.
[[nodiscard]] absl::StatusOr<EvalResult> RunEvaluation(
    const std::string& address, const std::vector<Variant>& variants, const EvalOptions& options,
    const std::function<void(int, int)>& progress);

// variant,trial,time_s,rse,rmse,trace,targets_found,path_length_m,collisions
// on the grid, one row per variant, trial and grid time.
[[nodiscard]] std::string TrialsCsv(const EvalResult& result);
// "variant,trial,target,in_view,detected,found" and a row per target of each
// finished trial: how often the camera had it in view, how often the
// detector reported it, and whether the final map finds it (1) or not (0).
[[nodiscard]] std::string TargetsCsv(const EvalResult& result);
// "variant,trial,target,time_s,altitude_m,detected,mean_after" and a row per
// time a target of a finished trial was in view (RunResult::sighting_log):
// when, from how high, whether the detector reported it (1) or not (0), and
// the highest map mean on its cells after that shot.
[[nodiscard]] std::string SightingsCsv(const EvalResult& result);
// A Markdown table, a row per variant in the order first seen: trials,
// failures, RSE at the start and the end (mean +- std, standard error),
// Tr(P) at the end (mean +- std), targets found (mean), trials that found
// every target (%), collisions, planning time per plan; then, per variant,
// the share of trials that found each target (by id); then every failed
// trial with its error.
[[nodiscard]] std::string SummaryMarkdown(const EvalResult& result, double budget_s);

}  // namespace oaipp::client
