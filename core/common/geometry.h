// Geometry vocabulary shared by every core module.
//
// World frame W: right-handed, z up, metres (docs/method.md §1). Points are
// Eigen::Vector3d in W unless a name says otherwise. The small LineOfSight
// interface lets the map ask "can the camera see this ground point?" without
// depending on how obstacles are stored.
//
//   Aabb volume{{-15, -15, 0}, {15, 15, 26}};
//   if (!volume.Contains(p_W)) { ... }
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "core/common/field_error.h"

namespace oaipp {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

// Axis-aligned box [min_W, max_W] in the world frame, metres.
struct Aabb {
  Vec3 min_W = Vec3::Zero();
  Vec3 max_W = Vec3::Zero();

  [[nodiscard]] Vec3 Size() const { return max_W - min_W; }
  [[nodiscard]] bool Contains(const Vec3& p_W, double margin_m = 0.0) const {
    return (p_W.array() >= min_W.array() - margin_m).all() &&
           (p_W.array() <= max_W.array() + margin_m).all();
  }
  [[nodiscard]] bool Intersects(const Aabb& other) const {
    return (min_W.array() <= other.max_W.array()).all() &&
           (other.min_W.array() <= max_W.array()).all();
  }
  [[nodiscard]] Aabb Inflated(double margin_m) const {
    return {min_W.array() - margin_m, max_W.array() + margin_m};
  }
  // The distance between the two boxes (0 when they meet): a lower bound on
  // the distance between anything inside them.
  [[nodiscard]] double Gap(const Aabb& other) const {
    return (min_W - other.max_W).cwiseMax(other.min_W - max_W).cwiseMax(0.0).norm();
  }
};

// True when every component is finite (no NaN, no infinity).
template <typename Derived>
[[nodiscard]] bool AllFinite(const Eigen::MatrixBase<Derived>& m) {
  return m.array().isFinite().all();
}

// Returns InvalidArgument naming `field` unless `value` is finite.
[[nodiscard]] inline absl::Status CheckFinite(absl::string_view field, double value) {
  if (std::isfinite(value)) return absl::OkStatus();
  return FieldError(absl::StatusCode::kInvalidArgument,
                    absl::StrCat("$0: must be finite, got ", value), {std::string(field)});
}

// Returns InvalidArgument naming `field` unless `value` > 0 and finite.
[[nodiscard]] inline absl::Status CheckPositive(absl::string_view field, double value) {
  if (std::isfinite(value) && value > 0.0) return absl::OkStatus();
  return FieldError(absl::StatusCode::kInvalidArgument,
                    absl::StrCat("$0: must be positive and finite, got ", value),
                    {std::string(field)});
}

// Returns InvalidArgument naming `field` unless every component is finite.
[[nodiscard]] inline absl::Status CheckFinite(absl::string_view field, const Vec3& v) {
  if (AllFinite(v)) return absl::OkStatus();
  return FieldError(absl::StatusCode::kInvalidArgument,
                    absl::StrCat("$0: must be finite, got (", v.x(), ", ", v.y(), ", ", v.z(), ")"),
                    {std::string(field)});
}

// Answers whether the straight segment between two world points is free of
// obstacles. Implemented by Environment; used by the camera model for
// occlusion so that mapping does not depend on environment.
class LineOfSight {
 public:
  virtual ~LineOfSight() = default;
  // True when the open segment from_W -> to_W meets no obstacle.
  [[nodiscard]] virtual bool IsVisible(const Vec3& from_W, const Vec3& to_W) const = 0;
};

constexpr double kPi = 3.14159265358979323846;
[[nodiscard]] constexpr double DegToRad(double deg) { return deg * kPi / 180.0; }

// A circle drawn as a regular polygon of `sides` vertices, counter-clockwise
// from the +x direction (for pictures and exports, not for distances).
[[nodiscard]] inline std::vector<Vec2> CircleAsPolygon(const Vec2& centre_W, double radius_m,
                                                       int sides) {
  std::vector<Vec2> ring;
  ring.reserve(static_cast<std::size_t>(sides));
  for (int k = 0; k < sides; ++k) {
    const double a = 2.0 * kPi * k / sides;
    ring.push_back(centre_W + radius_m * Vec2(std::cos(a), std::sin(a)));
  }
  return ring;
}

}  // namespace oaipp
