// Obstacles: named convex solids standing in the world (docs/method.md §2).
//
// Three shapes are supported: boxes (centre, full size, yaw about z),
// vertical cylinders (centre, radius, height) and prisms (a simple polygon
// footprint between a base and a top altitude, core/environment/prism.h).
// Each gives its exact signed distance (negative inside), its world bounding
// box and an exact test of whether a straight segment passes through it.
//
//   Obstacle building{"tower", Box{{0, -1, 13}, {10, 4, 26}, 0.0}};
//   OAIPP_RETURN_IF_ERROR(ValidateObstacle(building));
//   double d_m = SignedDistance(building, p_W);
#pragma once

#include <string>
#include <variant>
#include <vector>

#include "absl/status/status.h"
#include "core/common/geometry.h"
#include "core/environment/prism.h"

namespace oaipp {

// A box with centre centre_W, full edge lengths size_m (along its own x, y,
// z axes) and rotation yaw_rad about the world z axis.
struct Box {
  Vec3 centre_W = Vec3::Zero();
  Vec3 size_m = Vec3::Ones();
  double yaw_rad = 0.0;
};

// A cylinder with a vertical axis through centre_W (its mid-height point).
struct Cylinder {
  Vec3 centre_W = Vec3::Zero();
  double radius_m = 1.0;
  double height_m = 1.0;
};

using Shape = std::variant<Box, Cylinder, Prism>;

struct Obstacle {
  std::string id;
  Shape shape;
};

// OK when the shape's numbers are finite and its sizes strictly positive;
// otherwise InvalidArgument naming the field (prefixed by `field`).
[[nodiscard]] absl::Status ValidateShape(const Shape& shape, absl::string_view field = "shape");
// As ValidateShape, and the id must be non-empty.
[[nodiscard]] absl::Status ValidateObstacle(const Obstacle& obstacle);

// Exact signed Euclidean distance from p_W to the shape's surface, metres;
// negative inside. Precondition: the shape is valid.
[[nodiscard]] double SignedDistance(const Shape& shape, const Vec3& p_W);

// SignedDistance for many points of one shape (building a distance field):
// what depends only on the shape (a box's yaw) is worked out once. Values
// equal SignedDistance's bit for bit. Holds a pointer to `shape`.
class ShapeDistance {
 public:
  explicit ShapeDistance(const Shape& shape);
  [[nodiscard]] double operator()(const Vec3& p_W) const;
  // For many points on one vertical line: Column(x, y) once, then
  // AtHeight(column, p_W) for each point, equal to operator()(p_W).
  [[nodiscard]] double Column(const Vec2& xy_W) const;
  [[nodiscard]] double AtHeight(double column, const Vec3& p_W) const;

 private:
  const Shape* shape_;
  double cos_yaw_ = 1.0, sin_yaw_ = 0.0;
};

// Tight world-axis-aligned bounding box of the shape.
[[nodiscard]] Aabb BoundingBox(const Shape& shape);

// The shape's outline on the ground (world x, y, counter-clockwise): a box's
// four yawed corners, a cylinder's circle as a regular 32-gon through it, a
// prism's footprint.
// For pictures; geometry queries use the exact shape.
[[nodiscard]] std::vector<Vec2> GroundFootprint(const Shape& shape);

// True when the closed segment a_W -> b_W passes through the shape's interior
// over a parameter interval longer than `min_overlap` (a fraction of the
// segment, so that grazing contact does not count as a hit).
[[nodiscard]] bool SegmentHits(const Shape& shape, const Vec3& a_W, const Vec3& b_W,
                               double min_overlap = 1e-9);

// Smallest signed distance from any point of the segment a_W -> b_W to the
// shape. Exact up to 1e-9 m: the signed distance of a convex set is convex
// along a line, so golden-section search finds its minimum (a prism, which
// need not be convex, is searched triangle by triangle: exact while the
// segment stays outside, Prism::SegmentSignedDistance).
[[nodiscard]] double SegmentSignedDistance(const Shape& shape, const Vec3& a_W, const Vec3& b_W);

}  // namespace oaipp
