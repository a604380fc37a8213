// This folder's own geometry for airspace checks (tests/server/
// airspace_service_test.cc, home_service_test.cc): distances to a fence
// ring, a zone and a box computed here, independent of the server's code,
// and seeded random fences and zones.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include "absl/strings/str_cat.h"
#include "oaipp/v1/mission_service.pb.h"
#include "tests/server/team_fixture.h"

namespace oaipp::server::testing {

struct XY {
  double x, y;
};

// Distance from p to the segment [a, b].
inline double ToSegment(XY p, XY a, XY b) {
  const double ux = b.x - a.x, uy = b.y - a.y;
  const double t =
      std::clamp(((p.x - a.x) * ux + (p.y - a.y) * uy) / (ux * ux + uy * uy), 0.0, 1.0);
  return std::hypot(a.x + t * ux - p.x, a.y + t * uy - p.y);
}

// Signed distance to a ring's boundary, positive inside (crossing count).
inline double InsideRing(const std::vector<XY>& ring, XY p) {
  double nearest = std::numeric_limits<double>::infinity();
  bool inside = false;
  for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
    nearest = std::min(nearest, ToSegment(p, ring[j], ring[i]));
    if ((ring[i].y > p.y) != (ring[j].y > p.y) &&
        p.x < ring[j].x + (ring[i].x - ring[j].x) * (p.y - ring[j].y) / (ring[i].y - ring[j].y)) {
      inside = !inside;
    }
  }
  return inside ? nearest : -nearest;
}

inline std::vector<XY> RingOf(const v1::Ring& ring) {
  std::vector<XY> out;
  for (int i = 0; i + 1 < ring.xy_m_size(); i += 2) out.push_back({ring.xy_m(i), ring.xy_m(i + 1)});
  return out;
}

// The test's own distance from p to a zone (a cylinder, or a prism over a
// convex ring), positive outside.
inline double ToZone(const v1::Obstacle& zone, const Point& p) {
  double across = 0.0, lo = 0.0, hi = 0.0;
  if (zone.has_cylinder()) {
    const v1::Cylinder& c = zone.cylinder();
    across = std::hypot(p.x - c.centre_m().x(), p.y - c.centre_m().y()) - c.radius_m();
    lo = c.centre_m().z() - 0.5 * c.height_m();
    hi = c.centre_m().z() + 0.5 * c.height_m();
  } else {
    across = -InsideRing(RingOf(zone.prism().footprint()), {p.x, p.y});
    lo = zone.prism().base_m();
    hi = zone.prism().top_m();
  }
  const double up = std::max(lo - p.z, p.z - hi);
  const double outside = std::hypot(std::max(across, 0.0), std::max(up, 0.0));
  return outside > 0.0 ? outside : std::max(across, up);
}

// A star-shaped (concave) fence around the field's centre, radii 10-14 m.
inline v1::Fence RandomFence(std::mt19937& rng) {
  std::uniform_real_distribution<double> radius(10.0, 14.0);
  v1::Fence fence;
  const int n = 6 + static_cast<int>(rng() % 6);
  for (int k = 0; k < n; ++k) {
    const double a = 2.0 * std::numbers::pi * k / n, r = radius(rng);
    fence.mutable_polygon()->add_xy_m(r * std::cos(a));
    fence.mutable_polygon()->add_xy_m(r * std::sin(a));
  }
  return fence;
}

// Two cylinders and a square prism, floors 0-8 m, 6-14 m deep, none within
// 4 m of `start`.
inline void AddRandomZones(std::mt19937& rng, const Point& start, v1::MissionSpec& spec) {
  std::uniform_real_distribution<double> xy(-9.0, 9.0), size(1.0, 3.0), floor(0.0, 8.0),
      depth(6.0, 14.0);
  for (int i = 0; spec.no_fly_zones_size() < 3 && i < 200; ++i) {
    v1::Obstacle zone;
    zone.set_id(absl::StrCat("zone-", i));
    const double base = floor(rng), top = base + depth(rng), cx = xy(rng), cy = xy(rng);
    const double r = size(rng);
    if (spec.no_fly_zones_size() < 2) {
      v1::Cylinder& c = *zone.mutable_cylinder();
      c.mutable_centre_m()->set_x(cx);
      c.mutable_centre_m()->set_y(cy);
      c.mutable_centre_m()->set_z(0.5 * (base + top));
      c.set_radius_m(r);
      c.set_height_m(top - base);
    } else {
      v1::Prism& p = *zone.mutable_prism();
      for (const double v : {cx - r, cy - r, cx + r, cy - r, cx + r, cy + r, cx - r, cy + r}) {
        p.mutable_footprint()->add_xy_m(v);
      }
      p.set_base_m(base);
      p.set_top_m(top);
    }
    if (ToZone(zone, start) >= 4.0) *spec.add_no_fly_zones() = zone;
  }
}

// The nearest the path comes to leaving the fence or entering a zone,
// every 0.01 s.
inline double ClosestToAirspace(const v1::MissionSpec& spec, const v1::PlanPathResponse& path) {
  const Flight flight{.path = path};
  const std::vector<XY> fence = RingOf(spec.fence().polygon());
  double best = std::numeric_limits<double>::infinity();
  const double end = path.trajectory().duration_s();
  for (int i = 0; i * 0.01 <= end + 0.01; ++i) {
    const Point p = PositionAt(flight, std::min(i * 0.01, end));
    best = std::min(best, InsideRing(fence, {p.x, p.y}));
    for (const v1::Obstacle& zone : spec.no_fly_zones()) best = std::min(best, ToZone(zone, p));
  }
  return best;
}

// The test's own distance from p to an axis-aligned box obstacle (yaw 0),
// positive outside, negative inside.
inline double ToBox(const v1::Obstacle& obstacle, const Point& p) {
  const v1::Box& b = obstacle.box();
  const double d[3] = {std::abs(p.x - b.centre_m().x()) - 0.5 * b.size_m().x(),
                       std::abs(p.y - b.centre_m().y()) - 0.5 * b.size_m().y(),
                       std::abs(p.z - b.centre_m().z()) - 0.5 * b.size_m().z()};
  const double outside = std::hypot(std::max(d[0], 0.0), std::max(d[1], 0.0), std::max(d[2], 0.0));
  return outside > 0.0 ? outside : std::max({d[0], d[1], d[2]});
}

}  // namespace oaipp::server::testing
