#include "core/planning/return_home.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>

#include "absl/strings/str_format.h"
#include "core/common/status_macros.h"
#include "core/planning/baseline_planners.h"
#include "core/planning/stop_first.h"

namespace oaipp {

namespace {

// What a route keeps from obstacles beyond the planner's own clearance, so
// that the stop-and-go legs along it pass the exact check (whose chords
// bulge by a fraction of a millimetre).
constexpr double kRouteMargin_m = 0.05;

// The state at the end of `trajectory` begun at `start`'s mission time.
UavState EndOf(const PolynomialTrajectory& trajectory, double start_mission_s) {
  const double t = trajectory.Duration();
  return {.position_W = trajectory.Position(t),
          .velocity_W_m_s = trajectory.Velocity(t),
          .accel_W_m_s2 = trajectory.Acceleration(t),
          .mission_time_s = start_mission_s + t};
}

// From `from` (at rest) to `home` through `cruise_z`: up or down to it,
// around what is in the way at that height, and down or up to home.
// Nullopt when a vertical leg or the crossing is blocked.
std::optional<std::vector<Vec3>> RouteAt(const Environment& env, const Vec3& from, const Vec3& home,
                                         double cruise_z, double clearance, const Aabb& box) {
  const Vec3 up(from.x(), from.y(), cruise_z), over(home.x(), home.y(), cruise_z);
  std::vector<Vec3> route{from};
  const auto add = [&](const Vec3& p) {
    if ((p - route.back()).norm() > 1e-6) route.push_back(p);
  };
  if (!env.IsSegmentClear(from, up, clearance)) return std::nullopt;
  add(up);
  absl::StatusOr<std::vector<Vec3>> corners = DetourAround(env, up, over, clearance, box);
  if (!corners.ok()) return std::nullopt;
  for (const Vec3& c : *corners) add(c);
  add(over);
  if (!env.IsSegmentClear(over, home, clearance)) return std::nullopt;
  add(home);
  return route;
}

// The first t_s seconds of `trajectory` (0 < t_s < its duration): the
// same polynomials, the segment at t_s ending there.
absl::StatusOr<PolynomialTrajectory> PrefixOf(const PolynomialTrajectory& trajectory, double t_s) {
  std::vector<double> durations;
  std::vector<PolynomialTrajectory::SegmentCoefficients> coefficients;
  double start = 0.0;
  for (int i = 0; i < trajectory.NumSegments(); ++i) {
    const double d = trajectory.SegmentDurations()[i];
    coefficients.push_back(trajectory.Coefficients(i));
    if (start + d >= t_s) {
      durations.push_back(t_s - start);
      break;
    }
    durations.push_back(d);
    start += d;
  }
  return PolynomialTrajectory::FromCoefficients(std::move(durations), coefficients);
}

}  // namespace

absl::Status HomeConfig::Validate() const {
  OAIPP_RETURN_IF_ERROR(CheckFinite("home.position_m.x", home_W.x()));
  OAIPP_RETURN_IF_ERROR(CheckFinite("home.position_m.y", home_W.y()));
  OAIPP_RETURN_IF_ERROR(CheckFinite("home.position_m.z", home_W.z()));
  if (!(reserve_s >= 0.0) || !std::isfinite(reserve_s)) {
    return absl::InvalidArgumentError(
        absl::StrCat("home.reserve_s: must be >= 0 and finite, got ", reserve_s));
  }
  OAIPP_RETURN_IF_ERROR(CheckPositive("home.landing_speed_m_s", landing_speed_m_s));
  return absl::OkStatus();
}

absl::StatusOr<WayHome> PlanWayHome(const Environment& environment, const UavState& state,
                                    const Vec3& home_W, const PlannerLimits& limits) {
  // Brake first where the UAV moves: the legs start from rest.
  std::optional<PolynomialTrajectory> brake;
  Vec3 rest = state.position_W;
  if (!AtRest(state.velocity_W_m_s, state.accel_W_m_s2)) {
    OAIPP_ASSIGN_OR_RETURN(brake, PlanBrake(environment, state, limits));
    rest = brake->Position(brake->Duration());
  }
  const double clearance = limits.ObstacleClearance() + kRouteMargin_m;
  const Aabb& volume = environment.flight_volume();
  const Aabb box = volume.Inflated(-kRouteMargin_m);
  // Level with the higher end first; over everything else.
  std::vector<double> heights{std::max(rest.z(), home_W.z())};
  if (const double top = box.max_W.z() - clearance; top > heights.front() + 0.5) {
    heights.push_back(top);
  }
  for (const double z : heights) {
    std::optional<std::vector<Vec3>> route = RouteAt(environment, rest, home_W, z, clearance, box);
    if (!route.has_value()) continue;
    absl::StatusOr<PolynomialTrajectory> legs = PlanStopAndGo(*route, limits.dynamics);
    if (!legs.ok()) continue;
    PolynomialTrajectory trajectory = *std::move(legs);
    if (brake.has_value()) {
      OAIPP_ASSIGN_OR_RETURN(trajectory, Concatenate(*brake, trajectory));
    }
    if (!CheckTrajectoryExact(environment, trajectory, limits).ok()) continue;
    return WayHome{.trajectory = std::move(trajectory),
                   .route_W = *std::move(route),
                   .brake_s = brake.has_value() ? brake->Duration() : 0.0};
  }
  return absl::FailedPreconditionError(absl::StrFormat(
      "home: no collision-free way home from (%.1f, %.1f, %.1f) to (%.1f, %.1f, %.1f) keeping "
      "%.2f m (%s) from obstacles, no-fly zones and the fence",
      rest.x(), rest.y(), rest.z(), home_W.x(), home_W.y(), home_W.z(), limits.ObstacleClearance(),
      ClearanceRuleName(limits)));
}

absl::StatusOr<PlannedPath> ReturnHomePlanner::Plan(const PlanningContext& mission,
                                                    const UavState& state, absl::Time deadline) {
  if (mission.environment == nullptr) {
    return absl::InvalidArgumentError("mission.environment: required");
  }
  const Environment& env = *mission.environment;
  const PlannerLimits& limits = common_.limits;
  // What must stay unspent after the way home: the landing and the reserve.
  const double kept = home_.LandingSeconds() + home_.reserve_s;
  if (mission.remaining_budget_s > kept) {
    absl::StatusOr<PlannedPath> path = inner().Plan(mission, state, deadline);
    if (!path.ok()) return path.status();
    absl::StatusOr<WayHome> back =
        PlanWayHome(env, EndOf(path->trajectory, state.mission_time_s), home_.home_W, limits);
    if (back.ok()) {
      const double left = mission.remaining_budget_s - path->trajectory.Duration() -
                          back->trajectory.Duration() - home_.LandingSeconds();
      if (left >= home_.reserve_s) {
        path->way_home = std::move(back->trajectory);
        path->remaining_after_return_s = left;
        return path;
      }
    }
    // Else a prefix whose way home, braking first, fits: the longest such
    // eighth of the plan's duration, found by bisection.
    if (std::optional<PlannedPath> cut = CutForHome(mission, state, *path)) return *std::move(cut);
  }
  // No room for more search: the plan is the way home from here.
  const absl::Time started = absl::Now();
  OAIPP_ASSIGN_OR_RETURN(WayHome back, PlanWayHome(env, state, home_.home_W, limits));
  OAIPP_ASSIGN_OR_RETURN(PathScorer scorer, PathScorer::Create(mission, state, common_));
  ScoredPath scored = scorer.ScoreTrajectory(back.trajectory);
  if (!scored.ok()) {
    return absl::FailedPreconditionError("home: the way home could not be scored");
  }
  OAIPP_RETURN_IF_ERROR(scorer.CheckExact(*scored.trajectory));
  const double duration = back.trajectory.Duration();
  std::vector<Vec3> corners(back.route_W.begin() + 1, back.route_W.end());
  PlannerStats stats{.evaluations = 1,
                     .wall_time_s = absl::ToDoubleSeconds(absl::Now() - started),
                     .stop_reason = "way_home",
                     .stop_first_s = back.brake_s};
  PlannedPath path = scorer.Finish(std::move(scored), corners, std::move(stats));
  path.returning_home = true;
  path.remaining_after_return_s = mission.remaining_budget_s - duration - home_.LandingSeconds();
  return path;
}

std::optional<PlannedPath> ReturnHomePlanner::CutForHome(const PlanningContext& mission,
                                                         const UavState& state,
                                                         const PlannedPath& path) const {
  const PolynomialTrajectory& whole = path.trajectory;
  const double allowed = mission.remaining_budget_s - home_.LandingSeconds() - home_.reserve_s;
  // The way home from k / kCutSteps of the plan, if it fits.
  const auto fits = [&](int k) -> std::optional<WayHome> {
    const double t = whole.Duration() * k / kCutSteps;
    if (t >= allowed) return std::nullopt;
    const UavState at{.position_W = whole.Position(t),
                      .velocity_W_m_s = whole.Velocity(t),
                      .accel_W_m_s2 = whole.Acceleration(t),
                      .mission_time_s = state.mission_time_s + t};
    absl::StatusOr<WayHome> back =
        PlanWayHome(*mission.environment, at, home_.home_W, common_.limits);
    if (!back.ok() || t + back->trajectory.Duration() > allowed) return std::nullopt;
    return *std::move(back);
  };
  // Bisection over k in [1, kCutSteps - 1] for the latest that fits (a way
  // home is the costly part: three are tried, not seven). Fitting is nearly
  // monotone in k (later cuts leave less time); where it is not, a cut that
  // fits is still found, if not always the latest.
  int lo = 0, hi = kCutSteps;  // lo fits (0: none yet), hi does not
  std::optional<WayHome> best;
  while (hi - lo > 1) {
    const int k = (lo + hi) / 2;
    if (std::optional<WayHome> back = fits(k)) {
      lo = k;
      best = std::move(back);
    } else {
      hi = k;
    }
  }
  if (lo == 0) return std::nullopt;
  const double t = whole.Duration() * lo / kCutSteps;
  absl::StatusOr<PolynomialTrajectory> prefix = PrefixOf(whole, t);
  if (!prefix.ok()) return std::nullopt;
  absl::StatusOr<PathScorer> scorer = PathScorer::Create(mission, state, common_);
  if (!scorer.ok()) return std::nullopt;
  ScoredPath scored = scorer->ScoreTrajectory(*std::move(prefix));
  if (!scored.ok() || !scorer->CheckExact(*scored.trajectory).ok()) return std::nullopt;
  std::vector<Vec3> waypoints(scored.trajectory->Waypoints().begin() + 1,
                              scored.trajectory->Waypoints().end());
  PlannerStats stats = path.stats;
  stats.stop_reason = "cut_for_home";
  PlannedPath cut = scorer->Finish(std::move(scored), waypoints, std::move(stats));
  cut.remaining_after_return_s = allowed + home_.reserve_s - t - best->trajectory.Duration();
  cut.way_home = std::move(best->trajectory);
  return cut;
}

}  // namespace oaipp
