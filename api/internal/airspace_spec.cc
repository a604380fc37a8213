#include "api/internal/airspace_spec.h"

#include <cmath>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "api/geometry.h"
#include "api/internal/checks.h"
#include "api/limits.h"
#include "core/common/status_macros.h"

namespace oaipp::api::internal {
namespace {

absl::StatusOr<Fence> FenceFromProto(const v1::Fence& fence) {
  Fence out;
  switch (fence.shape_case()) {
    case v1::Fence::kPolygon: {
      const v1::Ring& ring = fence.polygon();
      // Bounded before anything is copied.
      if (ring.xy_m_size() > 2 * (kMaxPrismVertices + 1) || ring.xy_m_size() % 2 != 0) {
        return absl::InvalidArgumentError(
            absl::StrCat("spec.fence.polygon.xy_m: ", ring.xy_m_size(),
                         " values; x and y pairs of 3..", kMaxPrismVertices, " vertices"));
      }
      for (int i = 0; i + 1 < ring.xy_m_size(); i += 2) {
        const Vec2 v(ring.xy_m(i), ring.xy_m(i + 1));
        if (!(v.cwiseAbs().maxCoeff() <= kMaxCoordinateM)) {
          return absl::InvalidArgumentError(
              absl::StrCat("spec.fence.polygon.xy_m[", i, "]: vertex ", i / 2,
                           " must be finite and within ", kMaxCoordinateM, " m on each axis"));
        }
        out.polygon_W.push_back(v);
      }
      return out;
    }
    case v1::Fence::kCircle: {
      const v1::Circle& circle = fence.circle();
      for (const auto& [what, value] :
           {std::pair{"x_m", circle.x_m()}, std::pair{"y_m", circle.y_m()}}) {
        if (!(std::abs(value) <= kMaxCoordinateM)) {
          return absl::InvalidArgumentError(absl::StrCat(
              "spec.fence.circle.", what, ": must be finite and within ", kMaxCoordinateM, " m"));
        }
      }
      OAIPP_RETURN_IF_ERROR(
          CheckPositiveAtMost("spec.fence.circle.radius_m", circle.radius_m(), kMaxCoordinateM));
      out.centre_W = Vec2(circle.x_m(), circle.y_m());
      out.radius_m = circle.radius_m();
      return out;
    }
    case v1::Fence::SHAPE_NOT_SET:
      break;
  }
  return absl::InvalidArgumentError("spec.fence.shape: must be set (a polygon or a circle)");
}

}  // namespace

absl::Status FillAirspace(const v1::MissionSpec& spec, MissionConfig& c) {
  if (spec.no_fly_zones_size() > kMaxObstacles) {
    return absl::InvalidArgumentError(absl::StrCat("spec.no_fly_zones: ", spec.no_fly_zones_size(),
                                                   " zones; at most ", kMaxObstacles));
  }
  std::optional<Fence> fence;
  if (spec.has_fence()) {
    OAIPP_ASSIGN_OR_RETURN(fence, FenceFromProto(spec.fence()));
  }
  std::vector<Obstacle> zones;
  zones.reserve(static_cast<std::size_t>(spec.no_fly_zones_size()));
  for (int i = 0; i < spec.no_fly_zones_size(); ++i) {
    OAIPP_ASSIGN_OR_RETURN(
        Obstacle zone,
        ObstacleFromProto(spec.no_fly_zones(i), absl::StrCat("spec.no_fly_zones[", i, "]")));
    zones.push_back(std::move(zone));
  }
  const bool polygon = fence.has_value() && !fence->polygon_W.empty();
  OAIPP_ASSIGN_OR_RETURN(
      c.airspace,
      Airspace::Create(std::move(fence), std::move(zones),
                       polygon ? "spec.fence.polygon" : "spec.fence.circle", "spec.no_fly_zones"));
  return absl::OkStatus();
}

void WriteAirspace(const Airspace& airspace, v1::MissionSpec* spec) {
  if (const std::optional<Fence>& fence = airspace.fence(); fence.has_value()) {
    if (!fence->polygon_W.empty()) {
      v1::Ring& ring = *spec->mutable_fence()->mutable_polygon();
      for (const Vec2& v : fence->polygon_W) {
        ring.add_xy_m(v.x());
        ring.add_xy_m(v.y());
      }
    } else {
      v1::Circle& circle = *spec->mutable_fence()->mutable_circle();
      circle.set_x_m(fence->centre_W.x());
      circle.set_y_m(fence->centre_W.y());
      circle.set_radius_m(fence->radius_m);
    }
  }
  for (const Obstacle& zone : airspace.zones()) *spec->add_no_fly_zones() = ObstacleToProto(zone);
}

}  // namespace oaipp::api::internal
