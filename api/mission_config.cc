#include "api/mission_config.h"

#include <algorithm>
#include <cmath>

#include "core/common/status_macros.h"

namespace oaipp::api {

absl::StatusOr<FieldGrid> MissionConfig::MakeGrid() const {
  return FieldGrid::FromBounds(field_min_W, field_max_W, resolution_m);
}

double MissionConfig::CellCount() const {
  const double nx = std::round((field_max_W.x() - field_min_W.x()) / resolution_m);
  const double ny = std::round((field_max_W.y() - field_min_W.y()) / resolution_m);
  return std::max(0.0, nx * ny);
}

MapBackend MissionConfig::ResolveMapBackend(std::int64_t max_dense_cells) const {
  if (map_backend != MapBackend::kAuto) return map_backend;
  return CellCount() <= static_cast<double>(max_dense_cells) ? MapBackend::kDense
                                                             : MapBackend::kSparse;
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
