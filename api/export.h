// A planned path as autopilots load it (ExportPath): a QGroundControl .plan
// file, the same mission as MAVLink mission items (MAVSDK MissionRaw) and
// offboard setpoints in NED. docs/ground-stations.md explains the choices.
//
//   OAIPP_ASSIGN_OR_RETURN(ExportOptions options, ExportOptionsFromProto(request));
//   OAIPP_ASSIGN_OR_RETURN(v1::ExportPathResponse out,
//                          ExportPath(config, obstacles, request.path(), options));
//
// Waypoints are points of the trajectory itself, chosen (Douglas-Peucker
// over the trajectory sampled at 100 Hz) so that the trajectory stays
// within the tolerance of the straight legs between them; every camera
// shot is a waypoint followed by an image-capture command, and a speed
// command precedes each leg whose mean speed differs from the last one
// commanded by more than kSpeedStep_m_s.
#pragma once

#include <vector>

#include "absl/status/statusor.h"
#include "api/mission_config.h"
#include "core/environment/obstacle.h"
#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::api {

// MAVLink numbers the export writes.
inline constexpr int kMavFrameMission = 2;             // MAV_FRAME_MISSION
inline constexpr int kMavFrameGlobalRelativeAlt = 3;   // MAV_FRAME_GLOBAL_RELATIVE_ALT
inline constexpr int kMavCmdNavWaypoint = 16;          // MAV_CMD_NAV_WAYPOINT
inline constexpr int kMavCmdDoChangeSpeed = 178;       // MAV_CMD_DO_CHANGE_SPEED
inline constexpr int kMavCmdImageStartCapture = 2000;  // MAV_CMD_IMAGE_START_CAPTURE
inline constexpr int kQgcFirmwarePx4 = 12;             // MAV_AUTOPILOT_PX4
inline constexpr int kQgcFirmwareArduPilot = 3;        // MAV_AUTOPILOT_ARDUPILOTMEGA
inline constexpr int kQgcVehicleQuadrotor = 2;         // MAV_TYPE_QUADROTOR
// A new speed is commanded when a leg's mean speed differs by more than this.
inline constexpr double kSpeedStep_m_s = 0.5;
// The geofence's inclusion polygon is the field grown by this much (or by
// the UAV radius, if larger), so that a path on the volume's edge is inside.
inline constexpr double kFenceMargin_m = 1.0;

struct ExportOptions {
  double setpoint_rate_hz = 20.0;
  double waypoint_tolerance_m = 0.5;
  int max_items = 200;
  int firmware_type = kQgcFirmwarePx4;
};

// The request's options with defaults filled in; InvalidArgument naming
// the field ("setpoint_rate_hz", "waypoint_tolerance_m", "max_items",
// "autopilot") when out of range.
[[nodiscard]] absl::StatusOr<ExportOptions> ExportOptionsFromProto(
    const v1::ExportPathRequest& request);

// Exports `path` (a PlanPath answer) for the mission `config` with its
// current `obstacles`. Without config.geo_origin only the setpoints are
// filled (NED from W's origin). InvalidArgument naming "path.trajectory..."
// for a trajectory TrajectoryFromProto refuses, with more than 1000
// segments or longer than config.budget_s, "path.measurement_poses[i].t_s" outside the trajectory,
// and "setpoint_rate_hz" when the setpoints would exceed 200000; FailedPrecondition ("max_items:
// ...") when even a 100 m tolerance needs more than max_items items.
[[nodiscard]] absl::StatusOr<v1::ExportPathResponse> ExportPath(
    const MissionConfig& config, const std::vector<Obstacle>& obstacles,
    const v1::PlanPathResponse& path, const ExportOptions& options);

}  // namespace oaipp::api
