#include "api/mission_config.h"

#include "core/common/status_macros.h"

namespace oaipp::api {

absl::StatusOr<FieldGrid> MissionConfig::MakeGrid() const {
  return FieldGrid::FromBounds(field_min_W, field_max_W, resolution_m);
}

absl::StatusOr<Environment> MissionConfig::MakeEnvironment() const {
  OAIPP_ASSIGN_OR_RETURN(Environment env, Environment::Create(FlightVolume(), esdf));
  OAIPP_RETURN_IF_ERROR(env.Apply({.add = obstacles}));
  return env;
}

absl::StatusOr<CameraIntrinsics> MissionConfig::DefaultIntrinsics() const {
  return IntrinsicsForFov(kDefaultImageWidthPx, kDefaultImageHeightPx, camera.fov_x_deg,
                          camera.fov_y_deg);
}

}  // namespace oaipp::api
