// proto <-> core for planned paths: the server writes PlanPathResponse from
// a PlannedPath; a client reads the trajectory back into the core's
// polynomial type to fly it.
//
//   PlannedPathToProto(path, &response);                                           // server
//   OAIPP_ASSIGN_OR_RETURN(PolynomialTrajectory t, TrajectoryFromProto(response.trajectory()));
//   Vec3 p_W = t.Position(2.5);                                                     // client
#pragma once

#include "absl/status/statusor.h"
#include "core/planning/planner.h"
#include "core/trajectory/polynomial_trajectory.h"
#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::api {

// Samples per second of the sampled path in PlanPathResponse.
inline constexpr double kTrajectorySampleRate_hz = 10.0;

// Fills *out (cleared first) from a planned path: one segment per
// trajectory segment with its real-time coefficients (lowest order first,
// tau in seconds since the segment start), the duration, samples of
// position and velocity at the times SampleTrajectory gives for
// kTrajectorySampleRate_hz (t = 0, 0.1, 0.2, ... s below the duration, and
// the duration itself), the control waypoints, the measurement poses,
// objective, information, collision samples and verdict, the next shot
// time and the planner statistics.
void PlannedPathToProto(const PlannedPath& path, v1::PlanPathResponse* out);

// The trajectory of a PlanPathResponse as the core's polynomial type, so a
// client evaluates it with the same code that planned it. Missing
// coefficients are zero. InvalidArgument naming the field
// ("trajectory.segments: ...", "trajectory.segments[1].duration_s") for no
// segment, a duration that is not positive and finite, more than
// PolynomialTrajectory::kNumCoefficients coefficients or a non-finite one.
[[nodiscard]] absl::StatusOr<PolynomialTrajectory> TrajectoryFromProto(
    const v1::Trajectory& trajectory);

// A PlannedPath from a PlanPathResponse (a stored first answer, read back):
// PlannedPathToProto of the result equals `response`. Errors as
// TrajectoryFromProto.
[[nodiscard]] absl::StatusOr<PlannedPath> PlannedPathFromProto(
    const v1::PlanPathResponse& response);

// The UAV's state `t_s` seconds into `trajectory`, which it started at
// mission time `start_mission_time_s`: position, velocity and acceleration
// from the polynomial, the request's state for a replan from there (a
// replan mid-path, e.g. after a new obstacle).
[[nodiscard]] v1::UavState StateAlongPath(const PolynomialTrajectory& trajectory, double t_s,
                                          double start_mission_time_s);

}  // namespace oaipp::api
