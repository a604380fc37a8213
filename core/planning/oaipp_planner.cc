#include "core/planning/oaipp_planner.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <random>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/common/status_macros.h"
#include "core/planning/cmaes_optimizer.h"

namespace oaipp {
namespace {

// A scored path kept for the exact check, so it is not scored again.
struct Candidate {
  double score;
  Eigen::VectorXd x;
  ScoredPath path;
};

std::vector<Vec3> ToWaypoints(const Eigen::VectorXd& x) {
  std::vector<Vec3> w(static_cast<std::size_t>(x.size() / 3));
  for (std::size_t i = 0; i < w.size(); ++i) w[i] = x.segment<3>(3 * static_cast<Eigen::Index>(i));
  return w;
}

Eigen::VectorXd FromWaypoints(const std::vector<Vec3>& w) {
  Eigen::VectorXd x(3 * static_cast<Eigen::Index>(w.size()));
  for (std::size_t i = 0; i < w.size(); ++i) x.segment<3>(3 * static_cast<Eigen::Index>(i)) = w[i];
  return x;
}

}  // namespace

std::uint64_t MixSeed(std::uint64_t seed, double mission_time_s) {
  std::uint64_t z = seed ^ std::bit_cast<std::uint64_t>(mission_time_s);
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

absl::Status OaIppConfig::Validate() const {
  if (num_waypoints < 2 || num_waypoints > 20) {
    return absl::InvalidArgumentError(
        absl::StrCat("num_waypoints: must be in [2, 20], got ", num_waypoints));
  }
  if (greedy_altitudes_m.empty()) {
    return absl::InvalidArgumentError("greedy_altitudes_m: needs at least one layer");
  }
  for (double h : greedy_altitudes_m) OAIPP_RETURN_IF_ERROR(CheckPositive("greedy_altitudes_m", h));
  if (greedy_candidates_per_layer < 1) {
    return absl::InvalidArgumentError("greedy_candidates_per_layer: must be >= 1");
  }
  if (population < 5) {
    return absl::InvalidArgumentError(absl::StrCat("population: must be >= 5, got ", population));
  }
  if (generations < 0) return absl::InvalidArgumentError("generations: must be >= 0");
  if (stall_generations < 0) {
    return absl::InvalidArgumentError("stall_generations: must be >= 0");
  }
  if (!(stall_tolerance >= 0.0 && stall_tolerance <= 1.0)) {
    return absl::InvalidArgumentError("stall_tolerance: must be in [0, 1]");
  }
  for (int a = 0; a < 3; ++a) OAIPP_RETURN_IF_ERROR(CheckPositive("step_m", step_m[a]));
  if (exact_check_candidates < 1) {
    return absl::InvalidArgumentError("exact_check_candidates: must be >= 1");
  }
  return absl::OkStatus();
}

std::vector<Vec3> OaIppPlanner::GreedyStart(const PathScorer& scorer, std::uint64_t seed,
                                            absl::Time deadline, std::int64_t* evaluations) const {
  std::mt19937_64 rng(seed);
  const Aabb& box = scorer.waypoint_box();
  const FieldGrid& grid = scorer.grid();
  // Viewpoints above the field, inside the box.
  const Vec2 lo = grid.min_W().cwiseMax(box.min_W.head<2>());
  const Vec2 hi = grid.max_W().cwiseMin(box.max_W.head<2>());
  std::uniform_real_distribution<double> ux(lo.x(), hi.x()), uy(lo.y(), hi.y());
  const double clearance = common_.limits.ObstacleClearance();

  std::vector<PoseObservation> fused = scorer.start_observations();
  std::vector<Vec3> waypoints;
  Vec3 previous = scorer.state().position_W;
  bool out_of_time = false;
  for (int w = 1; w < config_.num_waypoints && !out_of_time; ++w) {
    double best_score = -std::numeric_limits<double>::infinity();
    Vec3 best = previous;  // hovering is the fallback when nothing is reachable
    // Adaptive: every candidate is one scored shot after `fused`, valued from
    // the variances predicted once per waypoint.
    Eigen::VectorXd variances;
    if (scorer.adaptive()) variances = scorer.PosteriorVariances(fused);
    // Layers take turns, so that a deadline cuts every layer alike.
    for (int k = 0; k < config_.greedy_candidates_per_layer && !out_of_time; ++k) {
      for (double h : config_.greedy_altitudes_m) {
        const double z = std::clamp(h, box.min_W.z(), box.max_W.z());
        const Vec3 p(ux(rng), uy(rng), z);
        if (best_score > -std::numeric_limits<double>::infinity() && absl::Now() >= deadline) {
          out_of_time = true;
          break;
        }
        if (!scorer.environment().IsSegmentClear(previous, p, clearance)) continue;
        PoseObservation shot = scorer.Observe(p);
        double information;
        if (scorer.adaptive()) {
          information = scorer.PoseValue(shot, variances);
        } else {
          std::vector<PoseObservation> poses = fused;
          poses.push_back(std::move(shot));
          information = scorer.Information(poses);
        }
        ++*evaluations;
        const double t = std::max(RampSegmentTime((p - previous).norm(), common_.limits.dynamics),
                                  scorer.weights().min_flight_time_s);
        const double score = scorer.weights().k1 * information / t;
        if (score > best_score) {
          best_score = score;
          best = p;
        }
      }
    }
    fused.push_back(scorer.Observe(best, /*scored=*/false));
    waypoints.push_back(best);
    previous = best;
  }
  return waypoints;
}

absl::StatusOr<PlannedPath> OaIppPlanner::Plan(const PlanningContext& mission,
                                               const UavState& state, absl::Time deadline) {
  const absl::Time started = absl::Now();
  OAIPP_RETURN_IF_ERROR(config_.Validate());
  OAIPP_ASSIGN_OR_RETURN(PathScorer scorer, PathScorer::Create(mission, state, common_));
  const std::uint64_t seed = MixSeed(common_.seed, state.mission_time_s);
  PlannerStats stats;
  const std::vector<Vec3> greedy = GreedyStart(scorer, seed, deadline, &stats.evaluations);

  // Every evaluated candidate without ESDF collisions competes for the
  // exact check; keep the best few.
  std::vector<Candidate> safe;
  auto remember = [&](const ScoredPath& path, const Eigen::VectorXd& x) {
    safe.push_back({path.score, x, path});
    std::sort(safe.begin(), safe.end(),
              [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
    if (safe.size() > static_cast<std::size_t>(config_.exact_check_candidates)) safe.pop_back();
  };
  const Eigen::VectorXd x0 = FromWaypoints(greedy);
  const ScoredPath greedy_scored = scorer.Score(greedy);
  ++stats.evaluations;
  stats.initial_objective = greedy_scored.score;
  if (greedy_scored.ok() && greedy_scored.collision_samples == 0) remember(greedy_scored, x0);

  stats.stop_reason = "greedy_only";
  const double fraction = std::clamp(mission.search_fraction, 1e-6, 1.0);
  const int generations =
      config_.generations > 0
          ? std::max(1, static_cast<int>(std::ceil(fraction * config_.generations - 1e-9)))
          : 0;
  stats.search_fraction = fraction;
  // Past the deadline CMA-ES would only score the greedy start again.
  const bool search = config_.refine && generations > 0;
  const bool late = absl::Now() >= deadline;
  if (search && late) stats.stop_reason = "deadline";
  if (search && !late) {
    // Candidates CMA-ES scored (the greedy start first), and those with a
    // trajectory within the dynamic limits (from a moving start PlanMinSnap
    // may find none).
    std::int64_t scored = 0, flyable = 0;
    const auto n = x0.size();
    Eigen::VectorXd lower(n), upper(n), steps(n);
    for (Eigen::Index i = 0; i < n; i += 3) {
      lower.segment<3>(i) = scorer.waypoint_box().min_W;
      upper.segment<3>(i) = scorer.waypoint_box().max_W;
      steps.segment<3>(i) = config_.step_m;
    }
    auto objective = [&](const Eigen::VectorXd& x) {
      const ScoredPath s = scorer.Score(ToWaypoints(x));
      ++scored;
      if (s.ok()) ++flyable;
      if (s.ok() && s.collision_samples == 0) remember(s, x);
      return -s.score;
    };
    const CmaesOptions options{
        .population = config_.population,
        .max_evaluations = static_cast<std::int64_t>(config_.population) * generations + 1,
        .seed = static_cast<std::uint32_t>(seed >> 32),
        .cancelled = mission.cancelled,
        // The greedy start and a whole generation around it without a
        // single trajectory: the start state is the obstacle, not the
        // waypoints, and more generations only burn the budget (a stop
        // first, core/planning/stop_first.h, can still plan).
        .give_up = [&] { return flyable == 0 && scored > config_.population; },
        .stall_generations = config_.stall_generations,
        .stall_tolerance = config_.stall_tolerance};
    OAIPP_ASSIGN_OR_RETURN(CmaesResult result,
                           MinimizeCmaes(objective, x0, steps, lower, upper, options, deadline));
    stats.evaluations += result.evaluations - 1;  // x0 was scored above already
    stats.generations = result.generations;
    stats.stop_reason = StopReasonName(result.stop_reason);
    if (result.stop_reason == StopReason::kCancelled) {
      return absl::CancelledError("planning cancelled by the caller");
    }
    if (result.stop_reason == StopReason::kGaveUp) {
      return absl::FailedPreconditionError(absl::StrFormat(
          "state: from %.2f m/s and %.2f m/s^2 none of the first %d candidate paths meets the "
          "speed and acceleration limits",
          state.velocity_W_m_s.norm(), state.accel_W_m_s2.norm(), scored));
    }
  }

  // Last resort: the first greedy viewpoint alone. It was chosen in straight
  // line of sight with clearance r / 2, and from rest a single minimum-snap
  // segment is that straight line.
  if (greedy.size() > 1)
    safe.push_back({-std::numeric_limits<double>::infinity(), FromWaypoints({greedy.front()}), {}});
  for (Candidate& c : safe) {
    std::vector<Vec3> waypoints = ToWaypoints(c.x);
    // Kept candidates carry their scored path; the fallback is scored only
    // if it is reached.
    ScoredPath s = c.path.ok() ? std::move(c.path) : scorer.Score(waypoints);
    if (!s.ok() || !scorer.CheckExact(*s.trajectory).ok()) continue;
    stats.wall_time_s = absl::ToDoubleSeconds(absl::Now() - started);
    return scorer.Finish(std::move(s), waypoints, std::move(stats));
  }
  if (absl::Now() >= deadline) {
    return absl::DeadlineExceededError("deadline passed before a collision-free path was found");
  }
  return absl::FailedPreconditionError(
      absl::StrCat("no collision-free path among ", safe.size(),
                   " candidates without ESDF collisions; the UAV may be boxed in"));
}

}  // namespace oaipp
