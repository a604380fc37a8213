#include "core/planning/stop_first.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/common/field_error.h"
#include "core/common/status_macros.h"
#include "core/planning/separation.h"
#include "core/trajectory/measurement_schedule.h"
#include "core/trajectory/min_snap.h"

namespace oaipp {
namespace {

// The brake's ramps, seconds, gentlest first: PlanBrake takes the first
// that keeps clear. Shorter ramps brake harder (more jerk) and stop closer
// to the straight stop at the acceleration limit.
constexpr double kBrakeRamps_s[] = {0.5, 0.3, 0.2, 0.1, 0.05, 0.03, 0.02};

bool Moving(const UavState& state) { return !AtRest(state.velocity_W_m_s, state.accel_W_m_s2); }

std::string Point(const Vec3& p) {
  return absl::StrFormat("(%.2f, %.2f, %.2f)", p.x(), p.y(), p.z());
}

// One segment whose acceleration blends from a_from to a_to by the quintic
// smoothstep h(x) = 10 x^3 - 15 x^4 + 6 x^5, x = tau / T: jerk and snap are
// zero at both ends. Integrated twice, with p and v at its start:
//   p(tau) = p + v tau + a_from tau^2 / 2
//            + (a_to - a_from) (tau^5 / (2 T^3) - tau^6 / (2 T^4) + tau^7 / (7 T^5)).
PolynomialTrajectory::SegmentCoefficients AccelerationBlend(const Vec3& p, const Vec3& v,
                                                            const Vec3& a_from, const Vec3& a_to,
                                                            double duration_s) {
  const double t = duration_s;
  const Vec3 b = a_to - a_from;
  PolynomialTrajectory::SegmentCoefficients c = PolynomialTrajectory::SegmentCoefficients::Zero();
  c.row(0) = p.transpose();
  c.row(1) = v.transpose();
  c.row(2) = 0.5 * a_from.transpose();
  c.row(5) = (0.5 / (t * t * t)) * b.transpose();
  c.row(6) = (-0.5 / (t * t * t * t)) * b.transpose();
  c.row(7) = (1.0 / (7.0 * t * t * t * t * t)) * b.transpose();
  return c;
}

// The brake for PlanBrake. The velocity to cancel, w = v0 + a0 T / 2 (the
// first ramp keeps part of a0), is split into its part along `first_axis`
// and the rest (no split for a zero axis); each part p is cancelled in turn
// by a constant acceleration -p / (T + hold), |.| <= a_max, held for
// hold = max(0, |p| / a_max - T), with ramps of T between: the ramps
// contribute (a_before + a_after) T / 2 each, so the velocity ends at zero.
absl::StatusOr<PolynomialTrajectory> BrakeWithRamps(const UavState& state, double ramp_s,
                                                    const Vec3& first_axis, double a_max) {
  const Vec3 w = state.velocity_W_m_s + state.accel_W_m_s2 * (0.5 * ramp_s);
  const Vec3 along = first_axis.dot(w) * first_axis;
  std::vector<Vec3> parts;
  for (const Vec3& part : {along, Vec3(w - along)}) {
    if (part.norm() > 1e-12) parts.push_back(part);
  }
  std::vector<double> durations;
  std::vector<PolynomialTrajectory::SegmentCoefficients> coefficients;
  Vec3 p = state.position_W, v = state.velocity_W_m_s, a = state.accel_W_m_s2;
  auto blend = [&](const Vec3& a_to) {
    durations.push_back(ramp_s);
    coefficients.push_back(AccelerationBlend(p, v, a, a_to, ramp_s));
    const Vec3 b = a_to - a;
    p += v * ramp_s + a * (0.5 * ramp_s * ramp_s) + b * (ramp_s * ramp_s / 7.0);
    v += a * ramp_s + b * (0.5 * ramp_s);
    a = a_to;
  };
  for (const Vec3& part : parts) {
    const double hold_s = std::max(0.0, part.norm() / a_max - ramp_s);
    blend(-part / (ramp_s + hold_s));
    if (hold_s > 0.0) {
      durations.push_back(hold_s);
      PolynomialTrajectory::SegmentCoefficients c =
          PolynomialTrajectory::SegmentCoefficients::Zero();
      c.row(0) = p.transpose();
      c.row(1) = v.transpose();
      c.row(2) = 0.5 * a.transpose();
      coefficients.push_back(c);
      p += v * hold_s + a * (0.5 * hold_s * hold_s);
      v += a * hold_s;
    }
  }
  blend(Vec3::Zero());
  return PolynomialTrajectory::FromCoefficients(std::move(durations), coefficients);
}

// The gradient of the exact signed distance at p_W (central differences):
// the direction away from the nearest obstacle or closed airspace; zero
// without either.
Vec3 DistanceGradient(const Environment& environment, const Vec3& p_W) {
  if (environment.obstacles().empty() && environment.airspace().empty()) return Vec3::Zero();
  constexpr double h = 1e-4;
  Vec3 g;
  for (int a = 0; a < 3; ++a) {
    Vec3 e = Vec3::Zero();
    e[a] = h;
    g[a] = (environment.SignedDistance(p_W + e) - environment.SignedDistance(p_W - e)) / (2 * h);
  }
  return g;
}

}  // namespace

StraightStop StraightStopOf(const UavState& state, const TrajectoryLimits& limits) {
  StraightStop stop;
  stop.from_W = state.position_W;
  stop.speed_m_s = state.velocity_W_m_s.norm();
  stop.distance_m = stop.speed_m_s * stop.speed_m_s / (2.0 * limits.max_accel_m_s2);
  stop.stop_W =
      stop.speed_m_s > 0.0
          ? Vec3(state.position_W + state.velocity_W_m_s / stop.speed_m_s * stop.distance_m)
          : state.position_W;
  return stop;
}

absl::Status CheckStraightStop(const Environment& environment, const UavState& state,
                               const PlannerLimits& limits) {
  const StraightStop stop = StraightStopOf(state, limits.dynamics);
  const std::string how =
      absl::StrFormat("stopping from %.2f m/s at $1 = %g takes %.2f m", stop.speed_m_s,
                      limits.dynamics.max_accel_m_s2, stop.distance_m);
  const Aabb& volume = environment.flight_volume();
  static constexpr const char* kAxis[] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    if (stop.stop_W[a] > volume.max_W[a]) {
      return FieldError(absl::StatusCode::kFailedPrecondition,
                        absl::StrCat("$0: ", how, " and would leave the flight volume through its ",
                                     kAxis[a], " max face at ", volume.max_W[a], " m"),
                        {"state.velocity_W_m_s", "limits.max_accel_m_s2"});
    }
    if (stop.stop_W[a] < volume.min_W[a]) {
      return FieldError(absl::StatusCode::kFailedPrecondition,
                        absl::StrCat("$0: ", how, " and would leave the flight volume through its ",
                                     kAxis[a], " min face at ", volume.min_W[a], " m"),
                        {"state.velocity_W_m_s", "limits.max_accel_m_s2"});
    }
  }
  const double clearance = limits.ObstacleClearance();
  if (const double d = environment.airspace().SegmentSignedDistance(stop.from_W, stop.stop_W);
      d < clearance) {
    return FieldError(absl::StatusCode::kFailedPrecondition,
                      absl::StrFormat("$0: %s and would come within %.2f m of the closed airspace "
                                      "(the fence or a no-fly zone; closer than %s = %g m)",
                                      how, std::max(d, 0.0), ClearanceRuleName(limits), clearance),
                      {"state.velocity_W_m_s", "limits.max_accel_m_s2"});
  }
  for (const auto& [id, obstacle] : environment.obstacles()) {
    const double d = SegmentSignedDistance(obstacle.shape, stop.from_W, stop.stop_W);
    if (d < clearance) {
      return FieldError(
          absl::StatusCode::kFailedPrecondition,
          absl::StrFormat("$0: %s and would come within %.2f m of obstacle '%s' "
                          "(closer than %s = %g m)",
                          how, std::max(d, 0.0), EscapeForFieldError(id.substr(0, 64)),
                          ClearanceRuleName(limits), clearance),
          {"state.velocity_W_m_s", "limits.max_accel_m_s2"});
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<PolynomialTrajectory> PlanBrake(const Environment& environment,
                                               const UavState& state, const PlannerLimits& limits) {
  // Braking along the velocity first; then, where that does not keep
  // clear, killing the velocity along one direction first (an axis, which
  // is a face's normal, or away from the nearest obstacle) and the rest
  // after: the whole acceleration limit then works against the approach.
  std::vector<Vec3> first_axes{Vec3::Zero(), Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ()};
  // Away from the obstacle nearest the UAV, and from the one nearest the
  // straight stop's end.
  for (const Vec3& p : {state.position_W, StraightStopOf(state, limits.dynamics).stop_W}) {
    const Vec3 away = DistanceGradient(environment, p);
    if (away.allFinite() && away.norm() > 0.5) first_axes.push_back(away.normalized());
  }
  absl::Status last = absl::OkStatus();
  for (double ramp_s : kBrakeRamps_s) {
    for (const Vec3& axis : first_axes) {
      absl::StatusOr<PolynomialTrajectory> brake =
          BrakeWithRamps(state, ramp_s, axis, limits.dynamics.max_accel_m_s2);
      if (!brake.ok()) return brake.status();
      if (brake->MaxSpeed() > limits.dynamics.max_speed_m_s * (1 + 1e-6) ||
          brake->MaxAcceleration() > limits.dynamics.max_accel_m_s2 * (1 + 1e-6)) {
        last = absl::FailedPreconditionError("over the speed or acceleration limit");
        continue;
      }
      if (absl::Status exact = CheckTrajectoryExact(environment, *brake, limits); !exact.ok()) {
        last = exact;
        continue;
      }
      return brake;
    }
  }
  // No brake keeps clear: say why the straight stop would not either, or,
  // where it would, that the smooth one does not.
  OAIPP_RETURN_IF_ERROR(CheckStraightStop(environment, state, limits));
  return absl::FailedPreconditionError(
      absl::StrCat("state: no smooth stop from ", Point(state.position_W), " at ",
                   absl::StrFormat("%.2f", state.velocity_W_m_s.norm()), " m/s keeps clear (",
                   last.message(), ")"));
}

absl::StatusOr<PolynomialTrajectory> Concatenate(const PolynomialTrajectory& first,
                                                 const PolynomialTrajectory& second) {
  std::vector<double> durations = first.SegmentDurations();
  durations.insert(durations.end(), second.SegmentDurations().begin(),
                   second.SegmentDurations().end());
  std::vector<PolynomialTrajectory::SegmentCoefficients> coefficients;
  coefficients.reserve(durations.size());
  for (int i = 0; i < first.NumSegments(); ++i) coefficients.push_back(first.Coefficients(i));
  for (int i = 0; i < second.NumSegments(); ++i) coefficients.push_back(second.Coefficients(i));
  return PolynomialTrajectory::FromCoefficients(std::move(durations), coefficients);
}

absl::StatusOr<PlannedPath> StopFirstPlanner::Plan(const PlanningContext& mission,
                                                   const UavState& state, absl::Time deadline) {
  if (!Moving(state)) return inner().Plan(mission, state, deadline);
  const absl::Time started = absl::Now();
  // The direct attempt gets half the time, so that stopping first has some.
  const absl::Time direct_deadline = deadline == absl::InfiniteFuture() || deadline <= started
                                         ? deadline
                                         : started + (deadline - started) / 2;
  absl::StatusOr<PlannedPath> direct = inner().Plan(mission, state, direct_deadline);
  if (direct.ok() ||
      !(absl::IsFailedPrecondition(direct.status()) || absl::IsDeadlineExceeded(direct.status()))) {
    return direct;
  }
  if (mission.environment == nullptr) return direct;

  OAIPP_ASSIGN_OR_RETURN(PolynomialTrajectory brake,
                         PlanBrake(*mission.environment, state, limits_));
  const double t_brake = brake.Duration();
  if (t_brake >= mission.remaining_budget_s) {
    return absl::FailedPreconditionError(absl::StrFormat(
        "state: no safe path from the UAV's state, and braking to rest takes %.2f s of the "
        "%.2f s of flight time left",
        t_brake, mission.remaining_budget_s));
  }
  OAIPP_ASSIGN_OR_RETURN(
      MeasurementSchedule shots,
      ScheduleMeasurements(
          {.trajectory_start_mission_s = state.mission_time_s,
           .duration_s = t_brake,
           .rate_hz = mission.camera.rate_hz,
           .next_shot_mission_s = std::max(mission.next_shot_mission_s, state.mission_time_s)}));
  UavState rest;
  rest.position_W = brake.Position(t_brake);
  rest.mission_time_s = state.mission_time_s + t_brake;
  PlanningContext after_stop = mission;
  after_stop.next_shot_mission_s = shots.next_shot_mission_s;
  after_stop.remaining_budget_s = mission.remaining_budget_s - t_brake;
  absl::StatusOr<PlannedPath> planned = inner().Plan(after_stop, rest, deadline);
  if (!planned.ok()) {
    return absl::Status(planned.status().code(),
                        absl::StrCat("no safe path from the UAV's state (",
                                     direct.status().message(), "), nor after braking to rest at ",
                                     Point(rest.position_W), ": ", planned.status().message()));
  }

  PlannedPath out = *std::move(planned);
  OAIPP_ASSIGN_OR_RETURN(out.trajectory, Concatenate(brake, out.trajectory));
  std::vector<MeasurementPose> poses;
  poses.reserve(shots.times_s.size() + out.measurement_poses.size());
  for (double t : shots.times_s) {
    poses.push_back({t, state.mission_time_s + t, brake.Position(t)});
  }
  for (MeasurementPose pose : out.measurement_poses) {
    pose.t_s += t_brake;
    poses.push_back(pose);
  }
  out.measurement_poses = std::move(poses);
  out.control_waypoints_W.insert(out.control_waypoints_W.begin(), state.position_W);
  // Both parts passed the exact check on their own; the whole is checked
  // again, as one trajectory, before it is returned.
  if (absl::Status exact = CheckTrajectoryExact(*mission.environment, out.trajectory, limits_);
      !exact.ok()) {
    return absl::InternalError(
        absl::StrCat("stop-first path failed its exact check: ", exact.message()));
  }
  // The brake was chosen against obstacles only; the planned part after it
  // against teammates too. The whole must keep clear of them.
  if (!mission.teammates.empty()) {
    OAIPP_RETURN_IF_ERROR(CheckSeparationExact(out.trajectory, state.mission_time_s,
                                               mission.teammates, mission.min_separation_m,
                                               limits_.exact_check_spacing_m));
  }
  out.stats.stop_first_s = t_brake;
  out.stats.wall_time_s = absl::ToDoubleSeconds(absl::Now() - started);
  return out;
}

}  // namespace oaipp
