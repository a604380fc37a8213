// proto <-> core for vectors, obstacles and the UAV state.
//
// *FromProto functions validate and answer a bad value with InvalidArgument
// whose message starts with the API's path of the field, given as `field`
// ("add[2].box.size_m.y", "spec.start.position_m.x"). Angles are degrees at
// the API and radians in the core. *ToProto functions cannot fail.
//
//   OAIPP_ASSIGN_OR_RETURN(Obstacle o, ObstacleFromProto(request.add(2), "add[2]"));
//   OAIPP_ASSIGN_OR_RETURN(UavState s, UavStateFromProto(request.state(), "state"));
#pragma once

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/common/geometry.h"
#include "core/environment/environment.h"
#include "core/environment/obstacle.h"
#include "core/planning/planner.h"
#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::api {

// Component-wise copies; no validation (callers check finiteness where the
// field is documented finite).
[[nodiscard]] v1::Vector3 ToProto(const Vec3& v);
[[nodiscard]] Vec3 FromProto(const v1::Vector3& v);

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

// InvalidArgument naming `field` + the sub-field ("spec.start.position_m.x")
// when a component is not finite or mission_time_s is negative. Unset
// vectors are zero. Range checks against the flight volume and limits are
// the caller's.
[[nodiscard]] absl::StatusOr<UavState> UavStateFromProto(const v1::UavState& state,
                                                         absl::string_view field);
[[nodiscard]] v1::UavState UavStateToProto(const UavState& state);

}  // namespace oaipp::api
