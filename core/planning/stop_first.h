// Planning from a moving start by stopping first (docs/method.md §7.7).
//
// A UAV that replans mid-flight may be moving fast towards a face of the
// flight volume or an obstacle, where no path the planner tries from that
// state keeps clear: the minimum-snap polynomials carry the start velocity
// on. StopFirstPlanner wraps any planner. It first plans from the state as
// given; if that finds no safe path and the UAV is moving, it brakes to rest
// on a short smooth segment along its velocity and plans the informative
// path from there, returning both as one trajectory.
//
// Where braking itself is not safe, the refusal names the cause: the face
// of the flight volume or the obstacle the straight stop (at the
// acceleration limit, along the velocity) would reach, and the speed.
//
//   auto planner = std::make_unique<StopFirstPlanner>(std::move(inner), common.limits);
//   OAIPP_ASSIGN_OR_RETURN(PlannedPath path, planner->Plan(context, moving_state, deadline));
//   // path.stats.stop_first_s > 0 when it braked first
#pragma once

#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/planning/path_scorer.h"
#include "core/planning/planner.h"

namespace oaipp {

// The straight stop from `state`: braking at max_accel_m_s2 along the
// velocity, from position_W to stop_W (|v|^2 / (2 a_max) further on).
struct StraightStop {
  Vec3 from_W = Vec3::Zero();
  Vec3 stop_W = Vec3::Zero();
  double speed_m_s = 0.0;
  double distance_m = 0.0;
};
[[nodiscard]] StraightStop StraightStopOf(const UavState& state, const TrajectoryLimits& limits);

// OK when the straight stop ends inside the flight volume and keeps
// uav_radius_m / 2 from every obstacle (exact). Otherwise FailedPrecondition
// naming the face ("x max face at 15 m") or the obstacle (by id) it reaches,
// the speed and the stopping distance.
[[nodiscard]] absl::Status CheckStraightStop(const Environment& environment, const UavState& state,
                                             const PlannerLimits& limits);

// A smooth brake to rest from `state`, close to the straight stop: the
// acceleration blends from the state's to a constant braking acceleration
// of at most max_accel_m_s2 against the velocity, holds, and blends to zero
// (quintic smoothstep ramps, so jerk and snap are continuous and zero at both
// ends). Ramps of 0.5 s are tried first, then shorter ones down to 0.05 s,
// until one passes the speed and acceleration limits and the exact check.
// FailedPrecondition when none does: CheckStraightStop's message when the
// straight stop is unsafe too.
[[nodiscard]] absl::StatusOr<PolynomialTrajectory> PlanBrake(const Environment& environment,
                                                             const UavState& state,
                                                             const PlannerLimits& limits);

// `first` followed by `second`, as one trajectory (`second` starts where
// `first` ends; continuity is the caller's).
[[nodiscard]] absl::StatusOr<PolynomialTrajectory> Concatenate(const PolynomialTrajectory& first,
                                                               const PolynomialTrajectory& second);

class StopFirstPlanner final : public WrappingPlanner {
 public:
  StopFirstPlanner(std::unique_ptr<Planner> inner, const PlannerLimits& limits)
      : WrappingPlanner(std::move(inner)), limits_(limits) {}

  // As the inner planner. From a moving start, a FailedPrecondition or
  // DeadlineExceeded of the direct attempt (which gets half the time left
  // when the deadline is finite) leads to the stop-first attempt; its
  // refusal names the straight stop's problem, or says that no path was
  // found after stopping.
  [[nodiscard]] absl::StatusOr<PlannedPath> Plan(const PlanningContext& mission,
                                                 const UavState& state,
                                                 absl::Time deadline) override;

 private:
  PlannerLimits limits_;
};

}  // namespace oaipp
