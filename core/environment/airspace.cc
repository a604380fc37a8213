#include "core/environment/airspace.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/environment/prism.h"

namespace oaipp {

absl::StatusOr<Airspace> Airspace::Create(std::optional<Fence> fence, std::vector<Obstacle> zones,
                                          absl::string_view fence_field,
                                          absl::string_view zones_field) {
  Airspace air;
  if (fence.has_value()) {
    if (!fence->polygon_W.empty()) {
      absl::StatusOr<std::vector<Vec2>> ring =
          SimplePolygon(std::move(fence->polygon_W), fence_field);
      if (!ring.ok()) return ring.status();
      fence->polygon_W = *std::move(ring);
    } else if (!AllFinite(fence->centre_W)) {
      return absl::InvalidArgumentError(absl::StrCat(fence_field, ".centre: must be finite"));
    } else if (!(fence->radius_m > 0.0 && std::isfinite(fence->radius_m))) {
      return absl::InvalidArgumentError(
          absl::StrCat(fence_field, ".radius_m: must be positive and finite"));
    }
    air.fence_ = std::move(fence);
  }
  std::set<std::string> ids;
  for (std::size_t i = 0; i < zones.size(); ++i) {
    const std::string where = absl::StrCat(zones_field, "[", i, "]");
    if (zones[i].id.empty()) return absl::InvalidArgumentError(where + ".id: must not be empty");
    if (!ids.insert(zones[i].id).second) {
      return absl::InvalidArgumentError(where + ".id: named twice");
    }
    if (absl::Status valid = ValidateShape(zones[i].shape, where); !valid.ok()) return valid;
    air.zone_boxes_.push_back(BoundingBox(zones[i].shape));
  }
  air.zones_ = std::move(zones);
  return air;
}

std::vector<Vec2> Airspace::FenceOutline() const {
  if (!fence_.has_value()) return {};
  if (!fence_->polygon_W.empty()) return fence_->polygon_W;
  return CircleAsPolygon(fence_->centre_W, fence_->radius_m, 64);
}

std::vector<std::vector<Vec2>> Airspace::ZoneFootprints() const {
  std::vector<std::vector<Vec2>> footprints;
  for (const Obstacle& zone : zones_) footprints.push_back(GroundFootprint(zone.shape));
  return footprints;
}

double Airspace::FenceSignedDistance(const Vec2& p_W) const {
  if (!fence_.has_value()) return std::numeric_limits<double>::infinity();
  if (fence_->polygon_W.empty()) return fence_->radius_m - (p_W - fence_->centre_W).norm();
  return -PolygonSignedDistance(fence_->polygon_W, p_W);
}

double Airspace::SignedDistance(const Vec3& p_W) const {
  double best = FenceSignedDistance(p_W.head<2>());
  const Aabb point{p_W, p_W};
  for (std::size_t i = 0; i < zones_.size(); ++i) {
    // As for segments: a zone whose box is farther than the best so far
    // cannot be nearer.
    if (point.Gap(zone_boxes_[i]) <= std::max(best, 0.0)) {
      best = std::min(best, oaipp::SignedDistance(zones_[i].shape, p_W));
    }
  }
  return best;
}

double Airspace::SegmentSignedDistance(const Vec3& a_W, const Vec3& b_W) const {
  double best = std::numeric_limits<double>::infinity();
  if (fence_.has_value()) {
    const Vec2 a = a_W.head<2>(), b = b_W.head<2>();
    const double at_a = FenceSignedDistance(a), at_b = FenceSignedDistance(b);
    if (at_a <= 0.0 || at_b <= 0.0) {
      best = std::min(at_a, at_b);
    } else if (fence_->polygon_W.empty()) {
      // The distance from the centre is convex along the segment: largest
      // at an end.
      best = std::min(at_a, at_b);
    } else {
      // Both ends inside: the nearest boundary point is on some edge (0 when
      // the segment crosses one and comes back).
      const std::vector<Vec2>& ring = fence_->polygon_W;
      for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
        best = std::min(best, SegmentToSegmentDistance(a, b, ring[j], ring[i]));
      }
    }
  }
  const Aabb seg{a_W.cwiseMin(b_W), a_W.cwiseMax(b_W)};
  for (std::size_t i = 0; i < zones_.size(); ++i) {
    // The gap between bounding boxes bounds the distance from below.
    if (seg.Gap(zone_boxes_[i]) <= std::max(best, 0.0)) {
      best = std::min(best, oaipp::SegmentSignedDistance(zones_[i].shape, a_W, b_W));
    }
  }
  return best;
}

}  // namespace oaipp
