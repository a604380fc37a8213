// proto <-> core for the mission spec: every default of the API is filled
// in here, from MissionConfig's initialisers (api/mission_config.h), and
// every field is validated.
//
//   OAIPP_ASSIGN_OR_RETURN(MissionConfig config, MissionSpecToConfig(request.spec()));
//   *mission.mutable_spec() = ConfigToMissionSpec(config);  // every default filled in
#pragma once

#include "absl/status/statusor.h"
#include "api/mission_config.h"
#include "core/planning/planners.h"
#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::api {

// PlannerKind <-> v1::PlannerKind. PLANNER_KIND_UNSPECIFIED means kOaIpp.
// A numeric value outside the enum (proto3 enums are open) is
// InvalidArgument "planner.kind: ...".
[[nodiscard]] v1::PlannerKind PlannerKindToProto(PlannerKind kind);
[[nodiscard]] absl::StatusOr<PlannerKind> PlannerKindFromProto(v1::PlannerKind kind);

// The core description of a mission from its spec. Unset optional fields
// take MissionConfig's defaults (the paper's values, documented in
// mission_service.proto; preset "" and "paper" mean the same defaults, the
// GP length scale default e^1.3 * resolution_m follows the chosen
// resolution). The objective follows the planner kind (ObjectiveFor).
// Settings the API does not expose (ESDF max_voxels, OA-IPP greedy layers,
// CMA-ES steps, score weights, ...) keep their core defaults.
//
// Fails with InvalidArgument naming the field ("spec.preset",
// "spec.field.x_max_m", "spec.obstacles[3].id", "spec.start.position_m", ...)
// for: an unknown preset; a non-finite number; a size, rate, variance or
// limit that must be positive and is not; sensor.detector_noise set with
// noise_a_var or noise_b_per_m, or out of range; a field extent that is not a
// whole number of cells; min_altitude_m >= max_altitude_m; a planner
// parameter out of range or an unknown planner kind; a bad or duplicate
// obstacle; a start that is not finite, lies outside the flight volume or
// exceeds the speed or acceleration limit; budget_s <= 0. ResourceExhausted
// ("spec.field: ...") when the field has more than FieldGrid::kMaxCells
// cells (the server's --max_cells is its own, lower limit). Obstacle clearance of the start is not
// checked here (that needs the environment). Geodetic points (*_geo) are converted to local metres
// at spec.geo_origin first (api/geodetic.h; errors name them).
[[nodiscard]] absl::StatusOr<MissionConfig> MissionSpecToConfig(const v1::MissionSpec& spec);

// The effective spec of `config`: every optional field set explicitly (of
// the sensor noise, noise_a_var and noise_b_per_m or detector_noise, the
// model in use; detector_noise.false_positive_rate only when given, unset
// being its own model) and the start always present, so that
// MissionSpecToConfig(ConfigToMissionSpec(c)) == c field for field for any c
// that MissionSpecToConfig returned
// (angles pass through degrees, so yaws agree to a few ulps).
[[nodiscard]] v1::MissionSpec ConfigToMissionSpec(const MissionConfig& config);

}  // namespace oaipp::api
