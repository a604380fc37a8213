// Tiny LineOfSight stand-ins for the mapping tests: the real one lives in
// core/environment, which mapping must not depend on.
#pragma once

#include "core/common/geometry.h"

namespace oaipp::testing {

// An infinitely tall, infinitely long wall in the plane x = x_wall_m: a
// segment is blocked when its end points lie strictly on opposite sides.
class WallAtX final : public LineOfSight {
 public:
  explicit WallAtX(double x_wall_m) : x_wall_m_(x_wall_m) {}
  bool IsVisible(const Vec3& from_W, const Vec3& to_W) const override {
    return (from_W.x() - x_wall_m_) * (to_W.x() - x_wall_m_) >= 0.0;
  }

 private:
  double x_wall_m_;
};

// Everything is hidden (e.g. the camera sits under a roof).
class BlockEverything final : public LineOfSight {
 public:
  bool IsVisible(const Vec3&, const Vec3&) const override { return false; }
};

}  // namespace oaipp::testing
