// proto <-> core conversion for the oaipp.v1 API: the only place where
// protobuf messages meet core types (STYLE.md habit 1).
//
// Every *FromProto function validates its input and answers a bad value with
// InvalidArgument whose message starts with the full path of the offending
// field, as the client sent it ("spec.field.resolution_m: must be positive
// and finite, got 0", "add[2].box.size_m.y: ...",
// "detections.boxes[1].x_max_px: ..."). Functions that convert a
// sub-message take that path as `field`. Units change at this boundary:
// the API speaks degrees, the core radians. *ToProto functions cannot fail:
// core values are valid by construction.
//
//   OAIPP_ASSIGN_OR_RETURN(MissionConfig config, MissionSpecToConfig(request.spec()));
//   *mission.mutable_spec() = ConfigToMissionSpec(config);  // every default filled in
//   OAIPP_ASSIGN_OR_RETURN(Obstacle o, ObstacleFromProto(request.add(2), "add[2]"));
//   OAIPP_ASSIGN_OR_RETURN(MeasurementInput m, MeasurementFromProto(request));
//   PlannedPathToProto(path, &response);
//   return ToGrpcStatus(status);  // in a service method
#pragma once

#include <string>

#include <grpcpp/support/status.h>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/common/geometry.h"
#include "core/environment/environment.h"
#include "core/environment/obstacle.h"
#include "core/mapping/gp_map.h"
#include "core/planning/planner.h"
#include "core/planning/planners.h"
#include "oaipp/v1/mission_service.pb.h"
#include "server/mission_config.h"

namespace oaipp::server {

// ---------------------------------------------------------------------------
// Vectors and enums.

// Component-wise copies; no validation (callers check finiteness where the
// field is documented finite).
[[nodiscard]] v1::Vector3 ToProto(const Vec3& v);
[[nodiscard]] Vec3 FromProto(const v1::Vector3& v);

// PlannerKind <-> v1::PlannerKind. PLANNER_KIND_UNSPECIFIED means kOaIpp.
// A numeric value outside the enum (proto3 enums are open) is
// InvalidArgument "planner.kind: ...".
[[nodiscard]] v1::PlannerKind PlannerKindToProto(PlannerKind kind);
[[nodiscard]] absl::StatusOr<PlannerKind> PlannerKindFromProto(v1::PlannerKind kind);

// ---------------------------------------------------------------------------
// Missions.

// The core description of a mission from its spec. Unset optional fields
// take the defaults documented in mission_service.proto (the paper's values;
// preset "" and "paper" mean the same defaults, the GP length scale default
// e^1.3 * resolution_m follows the chosen resolution). The planner's common
// settings carry the flight limits (limits.dynamics, uav_radius_m,
// sensor_rate_hz) and
// the information parameters, whose objective kind follows the planner kind.
// Settings the API does not expose (ESDF max_voxels, OA-IPP greedy layers,
// CMA-ES steps, score weights, ...) keep their core defaults. The start
// state's next_shot_mission_s and remaining_budget_s are not part of the
// API and keep their core defaults (0 and +infinity): the mission sets them.
//
// Fails with InvalidArgument naming the field ("spec.preset",
// "spec.field.x_max_m", "spec.obstacles[3].id", "spec.start.position_m", ...)
// for: an unknown preset; a non-finite number; a size, rate, variance or
// limit that must be positive and is not; a field extent that is not a
// whole number of cells; min_altitude_m >= max_altitude_m; a planner
// parameter out of range or an unknown planner kind; a bad or duplicate
// obstacle; a start that is not finite, lies outside the flight volume or
// exceeds the speed or acceleration limit; budget_s <= 0. ResourceExhausted
// ("spec.field: ...") when the field has more than FieldGrid::kMaxCells
// cells. Obstacle clearance of the start is not checked here (that needs
// the environment).
[[nodiscard]] absl::StatusOr<MissionConfig> MissionSpecToConfig(const v1::MissionSpec& spec);

// The effective spec of `config`: every optional field set explicitly and
// the start always present, so that MissionSpecToConfig(ConfigToMissionSpec(
// c)) == c field for field for any c that MissionSpecToConfig returned
// (angles pass through degrees, so yaws agree to a few ulps).
[[nodiscard]] v1::MissionSpec ConfigToMissionSpec(const MissionConfig& config);

// ---------------------------------------------------------------------------
// Obstacles.

// An obstacle from the API, the box yaw converted from degrees to radians.
// InvalidArgument naming `field` + the sub-field ("add[2].id",
// "add[2].box.size_m.y", "add[2].shape") when the id is not 1..128
// characters, no shape is set, a number is not finite or a size is not > 0.
[[nodiscard]] absl::StatusOr<Obstacle> ObstacleFromProto(const v1::Obstacle& obstacle,
                                                         absl::string_view field);
[[nodiscard]] v1::Obstacle ObstacleToProto(const Obstacle& obstacle);

// The change of an UpdateObstacles request, each obstacle converted with
// ObstacleFromProto ("add[i]", "replace[i]"). InvalidArgument also for a
// removed id that is not 1..128 characters ("remove[i]") and for an id that
// appears more than once in the change (named at its second appearance).
// Whether ids exist is the environment's check (NotFound / AlreadyExists).
[[nodiscard]] absl::StatusOr<ObstacleChange> ObstacleChangeFromProto(
    const v1::UpdateObstaclesRequest& request);

// ---------------------------------------------------------------------------
// UAV state.

// InvalidArgument naming `field` + the sub-field ("spec.start.position_m.x")
// when a component is not finite or mission_time_s is negative. Unset
// vectors are zero. next_shot_mission_s and remaining_budget_s are not in
// the message and keep their core defaults (0, +infinity) for the caller to
// set. Range checks against the flight volume and limits are the caller's.
[[nodiscard]] absl::StatusOr<UavState> UavStateFromProto(const v1::UavState& state,
                                                         absl::string_view field);
[[nodiscard]] v1::UavState UavStateToProto(const UavState& state);

// ---------------------------------------------------------------------------
// Measurements.

// One AddMeasurement request in core terms (camera yaw in radians). Checks
// what needs no mission: mission_time_s finite and >= 0, camera_position_m
// finite with z > 0, camera_yaw_deg finite; exactly one of labels and
// detections ("data: ..." when neither). Labels: as many labels as cells,
// cells >= 0 and distinct, labels finite in [0, 1] (kept in the order
// given). Detections: intrinsics (when set) valid, every box finite with
// 0 <= min < max (and max <= the image size when intrinsics are given),
// confidences and min_confidence in [0, 1]. Cells against the grid, the
// camera against the flight volume and boxes against the default image are
// the mission's checks. Failures are InvalidArgument naming the field
// ("labels.cells[4]", "detections.intrinsics.fx_px",
// "detections.boxes[1].x_max_px").
[[nodiscard]] absl::StatusOr<MeasurementInput> MeasurementFromProto(
    const v1::AddMeasurementRequest& request);

// ---------------------------------------------------------------------------
// Plans and maps.

// Fills *out (cleared first) from a planned path: one segment per
// trajectory segment with its real-time coefficients (lowest order first,
// tau in seconds since the segment start), the duration, samples of
// position and velocity at t = 0, 0.1, 0.2, ... s (< duration) and at the
// duration itself, the control waypoints, the measurement poses, objective,
// information, collision samples and verdict, the next shot time and the
// planner statistics.
void PlannedPathToProto(const PlannedPath& path, v1::PlanPathResponse* out);

// Fills the grid description and Tr(P) of *out, and mean and variance
// (row-major, row along y) when include_cells. Leaves out->png alone.
void MapToProto(const GpMap& map, bool include_cells, v1::GetMapResponse* out);

// A PNG of the map: the mean (left) and the standard deviation (right),
// both coloured with viridis over [0, 1] (values outside are clipped, NaN
// shows as 0), north up (image row 0 is the grid's last row, the largest
// y), x to the right. Each cell is a square block of kMapPngCellPx pixels
// (fewer for grids over 256 cells wide or tall, so no image side exceeds
// about 2048 px per panel); the panels are separated by a white gap of
// kMapPngGapPx pixels. Deterministic. Internal if OpenCV fails to encode.
inline constexpr int kMapPngCellPx = 8;
inline constexpr int kMapPngGapPx = 8;
[[nodiscard]] absl::StatusOr<std::string> MapToPng(const GpMap& map);

// ---------------------------------------------------------------------------
// Errors.

// The same code (absl and gRPC share code numbers) and message.
[[nodiscard]] grpc::Status ToGrpcStatus(const absl::Status& status);

}  // namespace oaipp::server
