#include "core/environment/obstacle.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "core/environment/golden_section.h"

namespace oaipp {
namespace {

// Signed distance of a 2-D or 3-D "rounded box" from its per-axis excess q
// (|p| - half size): outside |max(q, 0)|, inside max_i q_i.
template <typename V>
double BoxDistanceFromExcess(const V& q) {
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

Vec3 ToBoxFrame(const Box& box, double c, double s, const Vec3& p_W) {
  const Vec3 d = p_W - box.centre_W;
  return {c * d.x() + s * d.y(), -s * d.x() + c * d.y(), d.z()};
}

Vec3 ToBoxFrame(const Box& box, const Vec3& p_W) {
  return ToBoxFrame(box, std::cos(box.yaw_rad), std::sin(box.yaw_rad), p_W);
}

double BoxSignedDistance(const Box& box, double c, double s, const Vec3& p_W) {
  const Vec3 q = ToBoxFrame(box, c, s, p_W).cwiseAbs() - 0.5 * box.size_m;
  return BoxDistanceFromExcess(q);
}

// Intersects the parameter interval [t0, t1] with {t : lo <= a + t d <= hi}.
void ClipSlab(double a, double d, double lo, double hi, double& t0, double& t1) {
  if (std::abs(d) < 1e-15) {
    if (a < lo || a > hi) t1 = -1.0;  // empty
    return;
  }
  double ta = (lo - a) / d;
  double tb = (hi - a) / d;
  if (ta > tb) std::swap(ta, tb);
  t0 = std::max(t0, ta);
  t1 = std::min(t1, tb);
}

}  // namespace

absl::Status ValidateShape(const Shape& shape, absl::string_view field) {
  if (const Box* box = std::get_if<Box>(&shape)) {
    if (auto s = CheckFinite(absl::StrCat(field, ".box.centre_W"), box->centre_W); !s.ok())
      return s;
    for (int i = 0; i < 3; ++i) {
      if (auto s = CheckPositive(absl::StrCat(field, ".box.size_m[", i, "]"), box->size_m[i]);
          !s.ok()) {
        return s;
      }
    }
    return CheckFinite(absl::StrCat(field, ".box.yaw_rad"), box->yaw_rad);
  }
  // A prism is checked when it is made (Prism::Create).
  if (std::holds_alternative<Prism>(shape)) return absl::OkStatus();
  const Cylinder& cyl = std::get<Cylinder>(shape);
  if (auto s = CheckFinite(absl::StrCat(field, ".cylinder.centre_W"), cyl.centre_W); !s.ok()) {
    return s;
  }
  if (auto s = CheckPositive(absl::StrCat(field, ".cylinder.radius_m"), cyl.radius_m); !s.ok()) {
    return s;
  }
  return CheckPositive(absl::StrCat(field, ".cylinder.height_m"), cyl.height_m);
}

absl::Status ValidateObstacle(const Obstacle& obstacle) {
  if (obstacle.id.empty()) return absl::InvalidArgumentError("obstacle.id: must not be empty");
  return ValidateShape(obstacle.shape, absl::StrCat("obstacle[", obstacle.id, "]"));
}

double SignedDistance(const Shape& shape, const Vec3& p_W) {
  if (const Box* box = std::get_if<Box>(&shape)) {
    return BoxSignedDistance(*box, std::cos(box->yaw_rad), std::sin(box->yaw_rad), p_W);
  }
  if (const Prism* prism = std::get_if<Prism>(&shape)) return prism->SignedDistance(p_W);
  const Cylinder& cyl = std::get<Cylinder>(shape);
  const double r = (p_W.head<2>() - cyl.centre_W.head<2>()).norm();
  const Vec2 q(r - cyl.radius_m, std::abs(p_W.z() - cyl.centre_W.z()) - 0.5 * cyl.height_m);
  return BoxDistanceFromExcess(q);
}

ShapeDistance::ShapeDistance(const Shape& shape) : shape_(&shape) {
  if (const Box* box = std::get_if<Box>(&shape)) {
    cos_yaw_ = std::cos(box->yaw_rad);
    sin_yaw_ = std::sin(box->yaw_rad);
  }
}

double ShapeDistance::operator()(const Vec3& p_W) const {
  if (const Box* box = std::get_if<Box>(shape_)) {
    return BoxSignedDistance(*box, cos_yaw_, sin_yaw_, p_W);
  }
  return SignedDistance(*shape_, p_W);
}

double ShapeDistance::Column(const Vec2& xy_W) const {
  if (const Prism* prism = std::get_if<Prism>(shape_)) {
    return PolygonSignedDistance(prism->footprint(), xy_W);
  }
  return 0.0;  // unused: boxes and cylinders are cheap whole
}

double ShapeDistance::AtHeight(double column, const Vec3& p_W) const {
  if (const Prism* prism = std::get_if<Prism>(shape_)) {
    return prism->SignedDistanceAbove(column, p_W.z());
  }
  return (*this)(p_W);
}

Aabb BoundingBox(const Shape& shape) {
  if (const Box* box = std::get_if<Box>(&shape)) {
    const double c = std::abs(std::cos(box->yaw_rad));
    const double s = std::abs(std::sin(box->yaw_rad));
    const Vec3 h = 0.5 * box->size_m;
    const Vec3 half(c * h.x() + s * h.y(), s * h.x() + c * h.y(), h.z());
    return {box->centre_W - half, box->centre_W + half};
  }
  if (const Prism* prism = std::get_if<Prism>(&shape)) return prism->BoundingBox();
  const Cylinder& cyl = std::get<Cylinder>(shape);
  const Vec3 half(cyl.radius_m, cyl.radius_m, 0.5 * cyl.height_m);
  return {cyl.centre_W - half, cyl.centre_W + half};
}

bool SegmentHits(const Shape& shape, const Vec3& a_W, const Vec3& b_W, double min_overlap) {
  double t0 = 0.0;
  double t1 = 1.0;
  if (const Box* box = std::get_if<Box>(&shape)) {
    const Vec3 a = ToBoxFrame(*box, a_W);
    const Vec3 d = ToBoxFrame(*box, b_W) - a;
    const Vec3 h = 0.5 * box->size_m;
    for (int i = 0; i < 3 && t0 <= t1; ++i) ClipSlab(a[i], d[i], -h[i], h[i], t0, t1);
    return t1 - t0 > min_overlap;
  }
  if (const Prism* prism = std::get_if<Prism>(&shape)) {
    return prism->SegmentHits(a_W, b_W, min_overlap);
  }
  const Cylinder& cyl = std::get<Cylinder>(shape);
  const Vec3 a = a_W - cyl.centre_W;
  const Vec3 d = b_W - a_W;
  ClipSlab(a.z(), d.z(), -0.5 * cyl.height_m, 0.5 * cyl.height_m, t0, t1);
  if (t1 - t0 <= min_overlap) return false;
  // |a_xy + t d_xy|^2 <= R^2  <=>  A t^2 + B t + C <= 0.
  const double qa = d.head<2>().squaredNorm();
  const double qb = 2.0 * a.head<2>().dot(d.head<2>());
  const double qc = a.head<2>().squaredNorm() - cyl.radius_m * cyl.radius_m;
  if (qa < 1e-24) return qc < 0.0;
  const double disc = qb * qb - 4.0 * qa * qc;
  if (disc <= 0.0) return false;
  const double root = std::sqrt(disc);
  t0 = std::max(t0, (-qb - root) / (2.0 * qa));
  t1 = std::min(t1, (-qb + root) / (2.0 * qa));
  return t1 - t0 > min_overlap;
}

double SegmentSignedDistance(const Shape& shape, const Vec3& a_W, const Vec3& b_W) {
  if (const Prism* prism = std::get_if<Prism>(&shape)) {
    return prism->SegmentSignedDistance(a_W, b_W);
  }
  const Vec3 d = b_W - a_W;
  // Golden-section search: enough iterations to shrink the bracket below
  // 1e-9 m of arc length on segments up to a few kilometres.
  return MinimumOfConvex([&](double t) { return SignedDistance(shape, a_W + t * d); }, d.norm());
}

std::vector<Vec2> GroundFootprint(const Shape& shape) {
  std::vector<Vec2> corners;
  if (const Box* b = std::get_if<Box>(&shape)) {
    const Vec2 half = 0.5 * b->size_m.head<2>();
    const double c = std::cos(b->yaw_rad), s = std::sin(b->yaw_rad);
    for (const Vec2& q : {Vec2(-half.x(), -half.y()), Vec2(half.x(), -half.y()),
                          Vec2(half.x(), half.y()), Vec2(-half.x(), half.y())}) {
      corners.push_back(b->centre_W.head<2>() + Vec2(c * q.x() - s * q.y(), s * q.x() + c * q.y()));
    }
  } else if (const Prism* prism = std::get_if<Prism>(&shape)) {
    corners = prism->footprint();
  } else if (const Cylinder* cyl = std::get_if<Cylinder>(&shape)) {
    corners = CircleAsPolygon(cyl->centre_W.head<2>(), cyl->radius_m, 32);
  }
  return corners;
}

}  // namespace oaipp
