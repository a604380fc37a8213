// Airspace: where a path may not go though a camera sees through it
// (docs/method.md §2.6). An inclusion fence the UAV never leaves (a simple
// polygon or a circle, at every altitude) and exclusion zones (no-fly
// prisms, cylinders or boxes, each between a floor and a ceiling). Paths keep
// the same clearance from them as from obstacles; unlike obstacles they hide
// nothing from the camera and cover no ground.
//
//   Fence fence{.polygon_W = {{-50, -50}, {50, -50}, {50, 50}, {-50, 50}}};
//   OAIPP_ASSIGN_OR_RETURN(Airspace air, Airspace::Create(fence, {tower_zone}));
//   double d_m = air.SignedDistance(p_W);  // negative outside the fence or in a zone
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/common/geometry.h"
#include "core/environment/obstacle.h"

namespace oaipp {

// A polygon (polygon_W, 3 to kMaxPrismVertices vertices, simple) or, when
// polygon_W is empty, a circle (centre_W, radius_m > 0).
struct Fence {
  std::vector<Vec2> polygon_W = {};
  Vec2 centre_W = Vec2::Zero();
  double radius_m = 0.0;
};

class Airspace {
 public:
  // No fence, no zone: nowhere is closed.
  Airspace() = default;
  // Validates `fence` (a polygon as SimplePolygon, stored counter-clockwise;
  // a circle's finite centre and positive finite radius) and `zones` (as
  // obstacles, ids unique).
  // InvalidArgument naming `fence_field` or `zones_field`[i] and the reason.
  [[nodiscard]] static absl::StatusOr<Airspace> Create(std::optional<Fence> fence,
                                                       std::vector<Obstacle> zones,
                                                       absl::string_view fence_field = "fence",
                                                       absl::string_view zones_field = "zones");

  [[nodiscard]] bool empty() const { return !fence_.has_value() && zones_.empty(); }
  // The fence, its polygon counter-clockwise without a closing vertex.
  [[nodiscard]] const std::optional<Fence>& fence() const { return fence_; }
  [[nodiscard]] const std::vector<Obstacle>& zones() const { return zones_; }

  // Signed distance to the closed airspace, metres, negative inside it: the
  // least of the fence's (the distance to its boundary in x, y, positive
  // inside the fence) and each zone's exact signed distance; +infinity when
  // empty.
  [[nodiscard]] double SignedDistance(const Vec3& p_W) const;
  // The least signed distance along a_W -> b_W: exact while the segment
  // stays outside the closed airspace, <= 0 otherwise (then possibly less
  // deep than the true one).
  [[nodiscard]] double SegmentSignedDistance(const Vec3& a_W, const Vec3& b_W) const;
  // For pictures: the fence's outline (a circle as a regular 64-gon
  // through it; empty without a fence) and each zone's ground footprint
  // (GroundFootprint).
  [[nodiscard]] std::vector<Vec2> FenceOutline() const;
  [[nodiscard]] std::vector<std::vector<Vec2>> ZoneFootprints() const;
  // The fence's signed distance alone (+infinity without a fence).
  [[nodiscard]] double FenceSignedDistance(const Vec2& p_W) const;

 private:
  std::optional<Fence> fence_;
  std::vector<Obstacle> zones_;
  std::vector<Aabb> zone_boxes_;  // bounding boxes, same order as zones_
};

}  // namespace oaipp
