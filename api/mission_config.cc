#include "api/mission_config.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "api/status.h"
#include "core/common/status_macros.h"

namespace oaipp::api {

Eigen::VectorXd MissionConfig::PriorMean(int num_cells) const {
  if (prior_map != nullptr) return *prior_map;
  return Eigen::VectorXd::Constant(num_cells, gp.prior_mean);
}

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
  env.SetAirspace(airspace);
  return env;
}

absl::Status MissionConfig::CheckUavId(absl::string_view uav_id, absl::string_view field) const {
  if (team.empty()) {
    if (uav_id.empty()) return absl::OkStatus();
    return absl::NotFoundError(
        absl::StrCat(field, ": the mission flies one UAV without a team (uav_id \"\"), got ",
                     EchoInput(uav_id)));
  }
  if (uav_id.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": required: the mission flies a team of ", team.size(), " UAVs"));
  }
  if (FindMember(uav_id) == nullptr) {
    return absl::NotFoundError(
        absl::StrCat(field, ": no UAV ", EchoInput(uav_id), " in the mission's team"));
  }
  return absl::OkStatus();
}

double MissionConfig::PairDistance(absl::string_view a, absl::string_view b) const {
  const PlannerLimits la = KitOf(a).limits;
  const PlannerLimits lb = KitOf(b).limits;
  return std::max(min_separation_m,
                  la.uav_radius_m + la.tracking_error_m + lb.uav_radius_m + lb.tracking_error_m);
}

UavKit MissionConfig::KitOf(absl::string_view uav_id) const {
  if (const TeamMember* member = FindMember(uav_id); member != nullptr) return member->kit;
  return {.camera = camera, .noise = noise, .limits = planner.common.limits};
}

PlannerConfig MissionConfig::PlannerFor(absl::string_view uav_id) const {
  PlannerConfig config = planner;
  config.common.limits = KitOf(uav_id).limits;
  return config;
}

absl::StatusOr<CameraIntrinsics> MissionConfig::DefaultIntrinsics(absl::string_view uav_id) const {
  const DownwardCamera own = KitOf(uav_id).camera;
  return IntrinsicsForFov(kDefaultImageWidthPx, kDefaultImageHeightPx, own.fov_x_deg,
                          own.fov_y_deg);
}

}  // namespace oaipp::api
