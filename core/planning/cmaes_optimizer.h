// Anytime CMA-ES over a box, on top of pagmo2's cmaes (Hansen's default
// weights and learning rates).
//
// pagmo sizes the initial search distribution from the box's widths; this
// wrapper instead takes an initial step per coordinate (e.g. (4, 4, 3) m for
// a waypoint, docs/method.md §7), by running pagmo in coordinates scaled by
// those steps over a wide box and projecting candidates onto the real box
// before evaluating them (plus a small penalty on the distance outside, so
// the mean is pulled back in). It runs one generation at a time, so it stops
// at the evaluation budget or the deadline, whichever comes first, and keeps
// the best point ever evaluated. Once the deadline passes (or the run is
// cancelled) no further point is evaluated, even within a generation.
//
//   CmaesOptions options{.population = 12, .max_evaluations = 540, .seed = 7};
//   auto result = MinimizeCmaes(f, x0, steps, lower, upper, options, deadline);
//   if (result.ok()) use(result->best_x);
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "Eigen/Core"
#include "absl/status/statusor.h"
#include "absl/time/time.h"

namespace oaipp {

struct CmaesOptions {
  // Candidates per generation (lambda). Valid: >= 5 (pagmo's minimum).
  int population = 12;
  // Stop after this many objective evaluations. Valid: >= population.
  std::int64_t max_evaluations = 540;
  // Seed of the sampling: the same seed gives the same run.
  std::uint32_t seed = 1;
  // Asked between generations; true stops the run (e.g. a cancelled call).
  std::function<bool()> cancelled = nullptr;
  // Asked between generations; true ends the run as not worth continuing
  // (e.g. no candidate so far could be evaluated at all).
  std::function<bool()> give_up = nullptr;
  // Stop once the best value found is no better than the best value
  // stall_generations generations before by more than stall_tolerance x
  // |that earlier value| (0: never; the budget and the deadline decide). Valid:
  // stall_generations >= 0, 0 <= stall_tolerance <= 1.
  int stall_generations = 0;
  double stall_tolerance = 0.0;
};

enum class StopReason { kEvaluationBudget, kDeadline, kCancelled, kGaveUp, kStalled };
[[nodiscard]] std::string StopReasonName(StopReason reason);

struct CmaesResult {
  Eigen::VectorXd best_x;  // inside the box
  double best_f = 0.0;
  std::int64_t evaluations = 0;  // counts the evaluation of x0
  int generations = 0;           // completed generations
  StopReason stop_reason = StopReason::kEvaluationBudget;
};

// Minimises f over the box [lower, upper] starting from x0 (projected onto
// the box) with initial per-coordinate steps `steps`. f is only ever called
// with points inside the box; it must be deterministic for a run to be
// reproducible. Returns InvalidArgument for mismatched sizes, non-finite
// numbers, non-positive steps, an empty box or bad options.
[[nodiscard]] absl::StatusOr<CmaesResult> MinimizeCmaes(
    const std::function<double(const Eigen::VectorXd&)>& f, const Eigen::VectorXd& x0,
    const Eigen::VectorXd& steps, const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
    const CmaesOptions& options, absl::Time deadline = absl::InfiniteFuture());

}  // namespace oaipp
