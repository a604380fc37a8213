// Minimum-snap trajectories through waypoints (docs/method.md §5).
//
// The unconstrained QP of Richter, Bry & Roy, "Polynomial trajectory
// planning for aggressive quadrotor flight in dense indoor environments"
// (ISRR 2013 / Springer 2016), Sec. 3: one degree-9 polynomial per segment
// and axis, minimising the integral of the squared snap, with the position
// fixed at every waypoint and derivatives 1..4 continuous but free at
// interior waypoints. The start has the UAV's velocity and acceleration
// (jerk and snap 0); the end is at rest (velocity .. snap 0).
//
// SolveMinSnap takes the segment durations as given. PlanMinSnap allocates
// them from a velocity ramp (RampSegmentTime) and scales them so that the
// speed and acceleration stay within TrajectoryLimits.
//
//   StartState start{.position_W = p_W, .velocity_W_m_s = v_W, .accel_W_m_s2 = a_W};
//   OAIPP_ASSIGN_OR_RETURN(PolynomialTrajectory traj,
//                          PlanMinSnap(start, {c2_W, c3_W}, TrajectoryLimits{}));
//   // traj.MaxSpeed() <= 5 m/s, traj.MaxAcceleration() <= 3 m/s^2
#pragma once

#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/common/geometry.h"
#include "core/trajectory/polynomial_trajectory.h"

namespace oaipp {

// Dynamic limits of the UAV (docs/method.md §5).
struct TrajectoryLimits {
  // Valid: positive and finite.
  double max_speed_m_s = 5.0;
  // Valid: positive and finite.
  double max_accel_m_s2 = 3.0;
};

// OK, or InvalidArgument naming the first bad field.
[[nodiscard]] absl::Status ValidateLimits(const TrajectoryLimits& limits);

// Whether a start counts as at rest: speed and acceleration at most 1e-6
// (m/s, m/s^2). A path's end state carries rounding residue (~1e-15 m/s),
// and a replan from there plans as from rest.
[[nodiscard]] bool AtRest(const Vec3& velocity_W_m_s, const Vec3& accel_W_m_s2);

// The UAV's state when the trajectory starts, in W.
struct StartState {
  Vec3 position_W = Vec3::Zero();
  Vec3 velocity_W_m_s = Vec3::Zero();
  Vec3 accel_W_m_s2 = Vec3::Zero();
};

// Time to cover `distance_m` from rest to rest on a trapezoidal velocity
// ramp (accelerate at a_max, cruise at v_max, decelerate at a_max):
//   t(d) = 2 sqrt(d / a)                  if d < v^2 / a (never reaching v),
//   t(d) = 2 v / a + (d - v^2 / a) / v    otherwise.
// Preconditions (asserted): distance_m >= 0 and ValidateLimits(limits).ok().
[[nodiscard]] double RampSegmentTime(double distance_m, const TrajectoryLimits& limits);

// Solves the minimum-snap problem through `waypoints_W` (N + 1 points) with
// the given N segment durations, starting with the given velocity and
// acceleration and ending at rest. Waypoints may repeat. The start jerk and
// snap are 0, or with free_start_jerk_snap chosen by the optimiser too (the
// UAV state carries no jerk; freeing it lets a start acceleration fade
// quickly instead of lasting a fixed fraction of the first segment).
//
// Each axis is an independent block-tridiagonal positive-definite system in
// the 4 (N - 1) free interior derivatives, solved in O(N) by block Cholesky
// after Jacobi scaling. Derivatives 0..4 are continuous to ~1e-12 relative
// for durations within a factor of 20 of each other, and to ~1e-8 with
// durations mixed freely over 0.1..60 s.
//
// Returns InvalidArgument (naming the field) for fewer than 2 waypoints, a
// duration count other than waypoints - 1, a non-finite number, or a
// duration that is not positive; Internal if the system is numerically
// singular (durations spanning many orders of magnitude).
[[nodiscard]] absl::StatusOr<PolynomialTrajectory> SolveMinSnap(
    const std::vector<Vec3>& waypoints_W, const std::vector<double>& segment_durations_s,
    const Vec3& start_velocity_W_m_s, const Vec3& start_accel_W_m_s2,
    bool free_start_jerk_snap = false);

// Plans the minimum-snap trajectory from `start` through
// `waypoints_after_start_W` that meets `limits` (docs/method.md §5):
//  1. Consecutive waypoints closer than 1e-6 m are merged (also with the
//     start position), so repeated points cost no time; Waypoints() of the
//     result lists the merged points. If nothing but the start remains, the
//     trajectory is one segment back to the start position (braking from
//     the start velocity; zero-length if the UAV is at rest).
//  2. Segment i gets RampSegmentTime of its straight-line length, floored
//     at 0.1 s; the first segment gets |v_off| / a_max more, v_off being
//     the part of the start velocity that does not point towards its end
//     (the time to cancel it at full acceleration).
//  3. All durations are scaled by one common factor k and the problem
//     re-solved until max speed <= v_max and max acceleration <= a_max
//     (both within 1e-6 relative, measured by MaxSpeed/MaxAcceleration) and
//     max(speed / v_max, sqrt(accel / a_max)) >= 0.999, i.e. the fastest
//     uniformly scaled trajectory to 0.1 %. From rest one step is exact
//     (speed scales as 1/k, acceleration as 1/k^2: two solves in all, and
//     a limit is met to rounding); with a non-zero start state it is not,
//     so secant steps in log k (typically 2-4 solves) are followed, if they
//     do not settle, by a scan and a bisection (at most ~70 solves).
//     From a moving start (above 1e-6 m/s or 1e-6 m/s^2; below that they
//     are 0, as at rest, unless that finds no scaling) the start jerk and
//     snap are free, since the state carries no jerk: held at 0, the start
//     acceleration would decay over the whole first segment, its
//     contribution to the speed growing with the durations, and many more
//     starts would find no scaling.
//  4. Only if that fails from a moving start: step 3 is retried with a
//     transition segment of 1 s, then 2 s, that carries on at the start
//     velocity (to p + v tau, its duration fixed) before the scaled
//     segments.
//
// Returns InvalidArgument for a bad field (empty waypoints, non-finite
// numbers, bad limits); FailedPrecondition if the start speed or
// acceleration exceeds its limit by more than 1e-6 relative, or if no
// scaling meets the limits. From rest that never happens. Over 2000 random
// moving starts (random directions, |v| uniform in [0, 5] m/s, |a| in
// [0, 3] m/s^2, two random waypoints in the E1 volume) 7.6 % fail, about
// half of them above 3.5 m/s while still accelerating forwards
// (PlanMinSnapTest.MostMovingStartsPlan). The caller may then hold the
// current plan or stop first (core/planning/stop_first.h).
[[nodiscard]] absl::StatusOr<PolynomialTrajectory> PlanMinSnap(
    const StartState& start, const std::vector<Vec3>& waypoints_after_start_W,
    const TrajectoryLimits& limits);

// Stop and go: one rest-to-rest leg per consecutive pair of `points_W`
// (the first is the start, at rest), each timed by PlanMinSnap. A single
// minimum-snap segment between two rests is the straight line between its
// ends, so the trajectory follows the polyline exactly and the UAV stops at
// every point: slower than a smooth route, but as clear as the polyline.
// Points closer than 1e-6 m to the previous one are skipped; fewer than two
// distinct points give a zero-length hover of 0.1 s.
// InvalidArgument for no points or a non-finite one, or bad limits.
[[nodiscard]] absl::StatusOr<PolynomialTrajectory> PlanStopAndGo(const std::vector<Vec3>& points_W,
                                                                 const TrajectoryLimits& limits);

}  // namespace oaipp
