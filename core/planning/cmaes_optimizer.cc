#include "core/planning/cmaes_optimizer.h"

#include <cmath>
#include <deque>
#include <limits>
#include <memory>
#include <utility>

#include "absl/strings/str_cat.h"
#include "pagmo/algorithms/cmaes.hpp"
#include "pagmo/population.hpp"
#include "pagmo/problem.hpp"

namespace oaipp {
namespace {

// pagmo's scaled search box is [-kHalfWidth, kHalfWidth] in step units, and
// its sigma0 is relative to the box width: sigma0 = 1 / (2 kHalfWidth) makes
// the initial step exactly one step unit per coordinate.
constexpr double kHalfWidth = 1e4;

struct Shared {
  std::function<double(const Eigen::VectorXd&)> f;
  Eigen::VectorXd x0, steps, lower, upper;
  Eigen::VectorXd best_x;
  double best_f = std::numeric_limits<double>::infinity();
  std::int64_t evaluations = 0;
  // Past the deadline (or once cancelled) the rest of a generation is not
  // evaluated: an expensive objective would overrun by a whole generation.
  absl::Time deadline = absl::InfiniteFuture();
  std::function<bool()> cancelled;
  bool stopped = false;

  // Maps a scaled candidate to the real box; returns the squared distance
  // (in step units) by which it lay outside.
  double ToBox(const pagmo::vector_double& u, Eigen::VectorXd& x) const {
    double outside2 = 0.0;
    x.resize(x0.size());
    for (Eigen::Index i = 0; i < x0.size(); ++i) {
      const double raw = x0[i] + steps[i] * u[static_cast<std::size_t>(i)];
      x[i] = std::clamp(raw, lower[i], upper[i]);
      const double out = (raw - x[i]) / steps[i];
      outside2 += out * out;
    }
    return outside2;
  }
};

// pagmo user-defined problem: the objective in scaled coordinates.
struct ScaledProblem {
  std::shared_ptr<Shared> shared;

  pagmo::vector_double fitness(const pagmo::vector_double& u) const {
    if (shared->evaluations > 0 && (shared->stopped || absl::Now() >= shared->deadline ||
                                    (shared->cancelled && shared->cancelled()))) {
      shared->stopped = true;
      return {std::numeric_limits<double>::max()};
    }
    Eigen::VectorXd x;
    const double outside2 = shared->ToBox(u, x);
    const double fx = shared->f(x);
    ++shared->evaluations;
    if (fx < shared->best_f) {
      shared->best_f = fx;
      shared->best_x = x;
    }
    // The penalty keeps the distribution near the box; it is small next to
    // any objective difference that matters and zero inside the box.
    return {fx + 1e-3 * outside2};
  }
  std::pair<pagmo::vector_double, pagmo::vector_double> get_bounds() const {
    const auto n = static_cast<std::size_t>(shared->x0.size());
    return {pagmo::vector_double(n, -kHalfWidth), pagmo::vector_double(n, kHalfWidth)};
  }
};

}  // namespace

std::string StopReasonName(StopReason reason) {
  switch (reason) {
    case StopReason::kEvaluationBudget:
      return "evaluation_budget";
    case StopReason::kDeadline:
      return "deadline";
    case StopReason::kCancelled:
      return "cancelled";
    case StopReason::kGaveUp:
      return "gave_up";
    case StopReason::kStalled:
      return "stalled";
  }
  return "unknown";
}

absl::StatusOr<CmaesResult> MinimizeCmaes(const std::function<double(const Eigen::VectorXd&)>& f,
                                          const Eigen::VectorXd& x0, const Eigen::VectorXd& steps,
                                          const Eigen::VectorXd& lower,
                                          const Eigen::VectorXd& upper, const CmaesOptions& options,
                                          absl::Time deadline) {
  const Eigen::Index n = x0.size();
  if (n == 0) return absl::InvalidArgumentError("x0: must not be empty");
  if (steps.size() != n || lower.size() != n || upper.size() != n) {
    return absl::InvalidArgumentError("steps, lower, upper: must have the size of x0");
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!std::isfinite(x0[i]) || !std::isfinite(lower[i]) || !std::isfinite(upper[i])) {
      return absl::InvalidArgumentError(absl::StrCat("x0/lower/upper[", i, "]: must be finite"));
    }
    if (!(steps[i] > 0.0) || !std::isfinite(steps[i])) {
      return absl::InvalidArgumentError(absl::StrCat("steps[", i, "]: must be positive"));
    }
    if (!(lower[i] <= upper[i])) {
      return absl::InvalidArgumentError(absl::StrCat("lower[", i, "]: exceeds upper"));
    }
  }
  if (options.population < 5) {
    return absl::InvalidArgumentError(
        absl::StrCat("population: must be at least 5, got ", options.population));
  }
  if (options.max_evaluations < 1) {
    return absl::InvalidArgumentError("max_evaluations: must be positive");
  }
  if (options.stall_generations < 0) {
    return absl::InvalidArgumentError("stall_generations: must be >= 0");
  }
  if (!(options.stall_tolerance >= 0.0 && options.stall_tolerance <= 1.0)) {
    return absl::InvalidArgumentError("stall_tolerance: must be in [0, 1]");
  }

  auto shared = std::make_shared<Shared>();
  shared->f = f;
  shared->x0 = x0.cwiseMax(lower).cwiseMin(upper);
  shared->steps = steps;
  shared->lower = lower;
  shared->upper = upper;
  shared->deadline = deadline;
  shared->cancelled = options.cancelled;

  CmaesResult result;
  try {
    pagmo::problem problem{ScaledProblem{shared}};
    pagmo::population population{problem};
    // The start point is evaluated once and seeds the whole population, so
    // the first mean is x0 and the best found is never worse than x0.
    const pagmo::vector_double u0(static_cast<std::size_t>(n), 0.0);
    const pagmo::vector_double f0 = population.get_problem().fitness(u0);
    for (int i = 0; i < options.population; ++i) population.push_back(u0, f0);

    // ftol and xtol below zero: never stop on flatness (the start population
    // is perfectly flat); the budget and the deadline decide.
    pagmo::cmaes cmaes(/*gen=*/1, -1, -1, -1, -1, /*sigma0=*/1.0 / (2.0 * kHalfWidth),
                       /*ftol=*/-1.0, /*xtol=*/-1.0, /*memory=*/true, /*force_bounds=*/false,
                       options.seed);
    result.stop_reason = StopReason::kEvaluationBudget;
    // The best value after each of the last stall_generations + 1 completed
    // generations (the start counts as generation 0), oldest first: the
    // stall rule compares the newest with the oldest.
    std::deque<double> best_after;
    if (options.stall_generations > 0) best_after.push_back(shared->best_f);
    while (shared->evaluations + options.population <= options.max_evaluations) {
      if (absl::Now() >= deadline) {
        result.stop_reason = StopReason::kDeadline;
        break;
      }
      if (options.cancelled && options.cancelled()) {
        result.stop_reason = StopReason::kCancelled;
        break;
      }
      if (options.give_up && options.give_up()) {
        result.stop_reason = StopReason::kGaveUp;
        break;
      }
      population = cmaes.evolve(population);
      if (shared->stopped) {  // cut short inside the generation
        const bool late = absl::Now() >= deadline;
        result.stop_reason = late ? StopReason::kDeadline : StopReason::kCancelled;
        break;
      }
      ++result.generations;
      const auto g = static_cast<std::size_t>(options.stall_generations);
      if (g > 0) {
        best_after.push_back(shared->best_f);
        if (best_after.size() > g + 1) best_after.pop_front();
        const double before = best_after.front();
        if (best_after.size() == g + 1 &&
            shared->best_f >= before - options.stall_tolerance * std::abs(before)) {
          result.stop_reason = StopReason::kStalled;
          break;
        }
      }
    }
  } catch (const std::exception& e) {
    return absl::InternalError(absl::StrCat("cmaes: ", e.what()));
  }
  result.best_x = shared->best_x;
  result.best_f = shared->best_f;
  result.evaluations = shared->evaluations;
  return result;
}

}  // namespace oaipp
