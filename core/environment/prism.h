// Prisms: a simple polygon footprint (a building's outline, convex or not)
// extruded vertically between a base and a top altitude (docs/method.md
// §2.1). A building from map data is one; so is a no-fly zone with a floor
// and a ceiling.
//
// A Prism is made only through Create, which checks the footprint (3 to
// kMaxPrismVertices finite vertices, a simple polygon of non-zero area, in
// either orientation), stores it counter-clockwise and cuts it into
// triangles (ear clipping), the convex parts the segment queries use.
//
//   OAIPP_ASSIGN_OR_RETURN(Prism hall, Prism::Create({{0, 0}, {20, 0}, {20, 8},
//                                                     {8, 8}, {8, 20}, {0, 20}}, 0.0, 12.0));
//   double d_m = hall.SignedDistance(p_W);
#pragma once

#include <array>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/common/geometry.h"

namespace oaipp {

// Most vertices a prism's footprint may have: OpenStreetMap's buildings
// rarely have more than a few dozen; more costs time in every segment query
// (one convex part per vertex).
inline constexpr int kMaxPrismVertices = 256;

class Prism {
 public:
  // The prism over `footprint_W` (vertices once each, a repeated closing
  // vertex dropped) from base_m to top_m (world z). InvalidArgument naming
  // `field` + ".footprint" (fewer than 3 distinct or more than
  // kMaxPrismVertices vertices, a non-finite one, two edges that cross or
  // touch, zero area) or + ".top_m" (not finite, or not above a finite
  // base_m).
  [[nodiscard]] static absl::StatusOr<Prism> Create(std::vector<Vec2> footprint_W, double base_m,
                                                    double top_m,
                                                    absl::string_view field = "prism");

  // Counter-clockwise, without the closing vertex.
  [[nodiscard]] const std::vector<Vec2>& footprint() const { return footprint_; }
  [[nodiscard]] double base_m() const { return base_m_; }
  [[nodiscard]] double top_m() const { return top_m_; }
  // The footprint cut into triangles (counter-clockwise each).
  [[nodiscard]] const std::vector<std::array<Vec2, 3>>& triangles() const { return triangles_; }

  // Exact signed distance to the prism's surface (negative inside): the
  // footprint's 2-D signed distance d and the height band's h combined as
  // for any product of a plane set and an interval, |(max(d, 0), max(h,
  // 0))| outside and max(d, h) inside.
  [[nodiscard]] double SignedDistance(const Vec3& p_W) const;
  // As SignedDistance(p_W), given the footprint's 2-D signed distance at
  // p_W's x, y (PolygonSignedDistance(footprint(), xy)): for many points on
  // one vertical line.
  [[nodiscard]] double SignedDistanceAbove(double footprint_distance, double z_m) const;
  [[nodiscard]] Aabb BoundingBox() const;
  // Whether a_W -> b_W runs inside over a parameter interval longer than
  // min_overlap (the union of the intervals inside each triangle's prism).
  [[nodiscard]] bool SegmentHits(const Vec3& a_W, const Vec3& b_W, double min_overlap) const;
  // The smallest signed distance along a_W -> b_W: the least over the
  // triangles' prisms, each convex and searched exactly. Exact (to 1e-9 m)
  // while the segment stays outside; a segment that enters gets a value
  // <= 0 that may be less deep than the true one.
  [[nodiscard]] double SegmentSignedDistance(const Vec3& a_W, const Vec3& b_W) const;

 private:
  Prism() = default;
  std::vector<Vec2> footprint_;
  double base_m_ = 0.0;
  double top_m_ = 0.0;
  std::vector<std::array<Vec2, 3>> triangles_;        // at most kMaxPrismVertices - 2
  std::vector<std::array<Vec2, 2>> triangle_bounds_;  // each triangle's (lo, hi)
  Vec2 lo_ = Vec2::Zero(), hi_ = Vec2::Zero();        // the footprint's bounds
};

// `vertices_W` checked as a simple polygon (3 to kMaxPrismVertices finite
// vertices once each, a repeated closing vertex dropped; no two edges
// crossing or touching; non-zero area) and returned counter-clockwise.
// InvalidArgument naming `field` and the reason otherwise.
[[nodiscard]] absl::StatusOr<std::vector<Vec2>> SimplePolygon(std::vector<Vec2> vertices_W,
                                                              absl::string_view field);

// The distance between the closed segments [a, b] and [c, d] (0 when they
// meet).
[[nodiscard]] double SegmentToSegmentDistance(const Vec2& a, const Vec2& b, const Vec2& c,
                                              const Vec2& d);

// Signed distance from p to a simple polygon (either orientation), negative
// inside: the nearest edge's distance, signed by the even-odd rule.
[[nodiscard]] double PolygonSignedDistance(const std::vector<Vec2>& polygon, const Vec2& p);

}  // namespace oaipp
