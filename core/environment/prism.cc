#include "core/environment/prism.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <span>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/environment/golden_section.h"

namespace oaipp {
namespace {

double Cross(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

double SegmentDistance(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

// Whether the closed segments [a, b] and [c, d] share a point.
bool SegmentsMeet(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  const double d1 = Cross(b - a, c - a), d2 = Cross(b - a, d - a);
  const double d3 = Cross(d - c, a - c), d4 = Cross(d - c, b - c);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) {
    return true;
  }
  const auto on = [](const Vec2& p, const Vec2& q, const Vec2& r, double cross) {
    // r on the segment [p, q], given cross = Cross(q - p, r - p).
    return cross == 0.0 && std::min(p.x(), q.x()) <= r.x() && r.x() <= std::max(p.x(), q.x()) &&
           std::min(p.y(), q.y()) <= r.y() && r.y() <= std::max(p.y(), q.y());
  };
  return on(a, b, c, d1) || on(a, b, d, d2) || on(c, d, a, d3) || on(c, d, b, d4);
}

// Signed distance to a counter-clockwise triangle, negative inside.
double TriangleSignedDistance(const std::array<Vec2, 3>& t, const Vec2& p) {
  double nearest = std::numeric_limits<double>::infinity();
  bool inside = true;
  for (int k = 0; k < 3; ++k) {
    const Vec2& a = t[k];
    const Vec2& b = t[(k + 1) % 3];
    nearest = std::min(nearest, SegmentDistance(p, a, b));
    inside = inside && Cross(b - a, p - a) >= 0.0;
  }
  return inside ? -nearest : nearest;
}

// The plane set's signed distance d and the height band's h combined.
double Combine(double d, double h) {
  if (d <= 0.0 && h <= 0.0) return std::max(d, h);
  return std::hypot(std::max(d, 0.0), std::max(h, 0.0));
}

// Whether p lies in the closed triangle a, b, c (counter-clockwise).
bool InTriangle(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& p) {
  return Cross(b - a, p - a) >= 0.0 && Cross(c - b, p - b) >= 0.0 && Cross(a - c, p - c) >= 0.0;
}

// Ear clipping of a simple counter-clockwise polygon; empty when no ear is
// found (rounding on a nearly degenerate outline).
std::vector<std::array<Vec2, 3>> Triangulate(const std::vector<Vec2>& polygon) {
  std::vector<int> left(polygon.size());
  std::iota(left.begin(), left.end(), 0);
  std::vector<std::array<Vec2, 3>> triangles;
  while (left.size() > 3) {
    const std::size_t n = left.size();
    bool clipped = false;
    for (std::size_t i = 0; i < n && !clipped; ++i) {
      const Vec2& a = polygon[left[(i + n - 1) % n]];
      const Vec2& b = polygon[left[i]];
      const Vec2& c = polygon[left[(i + 1) % n]];
      const double turn = Cross(b - a, c - b);
      if (turn == 0.0) {  // b on the line from a to c: no triangle
        left.erase(left.begin() + static_cast<std::ptrdiff_t>(i));
        clipped = true;
        break;
      }
      if (turn < 0.0) continue;  // reflex
      bool empty = true;
      for (std::size_t j = 0; j < n && empty; ++j) {
        const Vec2& q = polygon[left[j]];
        if (j == i || j == (i + 1) % n || j == (i + n - 1) % n || q == a || q == c) continue;
        empty = !InTriangle(a, b, c, q);
      }
      if (!empty) continue;
      triangles.push_back({a, b, c});
      left.erase(left.begin() + static_cast<std::ptrdiff_t>(i));
      clipped = true;
    }
    if (!clipped) return {};
  }
  const Vec2& a = polygon[left[0]];
  const Vec2& b = polygon[left[1]];
  const Vec2& c = polygon[left[2]];
  if (Cross(b - a, c - b) > 0.0) triangles.push_back({a, b, c});
  return triangles;
}

// [t0, t1] intersected with {t : c0 + c1 t >= 0}.
void ClipHalf(double c0, double c1, double& t0, double& t1) {
  if (std::abs(c1) < 1e-300) {
    if (c0 < 0.0) t1 = -1.0;
    return;
  }
  const double t = -c0 / c1;
  if (c1 > 0.0) {
    t0 = std::max(t0, t);
  } else {
    t1 = std::min(t1, t);
  }
}

}  // namespace

double SegmentToSegmentDistance(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  if (SegmentsMeet(a, b, c, d)) return 0.0;
  return std::min({SegmentDistance(a, c, d), SegmentDistance(b, c, d), SegmentDistance(c, a, b),
                   SegmentDistance(d, a, b)});
}

double PolygonSignedDistance(const std::vector<Vec2>& polygon, const Vec2& p) {
  double nearest = std::numeric_limits<double>::infinity();
  bool inside = false;
  for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
    const Vec2& a = polygon[j];
    const Vec2& b = polygon[i];
    nearest = std::min(nearest, SegmentDistance(p, a, b));
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x()) {
      inside = !inside;
    }
  }
  return inside ? -nearest : nearest;
}

absl::StatusOr<std::vector<Vec2>> SimplePolygon(std::vector<Vec2> vertices_W,
                                                absl::string_view field) {
  const std::string where(field);
  if (vertices_W.size() > static_cast<std::size_t>(kMaxPrismVertices) + 1) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": ", vertices_W.size(), " vertices, more than ", kMaxPrismVertices));
  }
  for (std::size_t i = 0; i < vertices_W.size(); ++i) {
    if (!AllFinite(vertices_W[i])) {
      return absl::InvalidArgumentError(absl::StrCat(where, "[", i, "]: must be finite"));
    }
  }
  // Repeated vertices (a closing one, or doubled in the data) say nothing.
  std::vector<Vec2> ring;
  for (const Vec2& v : vertices_W) {
    if (ring.empty() || v != ring.back()) ring.push_back(v);
  }
  while (ring.size() > 1 && ring.front() == ring.back()) ring.pop_back();
  if (ring.size() < 3) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": needs at least 3 distinct vertices, got ", ring.size()));
  }
  if (ring.size() > static_cast<std::size_t>(kMaxPrismVertices)) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": ", ring.size(), " vertices, more than ", kMaxPrismVertices));
  }
  const std::size_t n = ring.size();
  // Simple: edges meet only where they follow each other, at their shared
  // vertex (and not along a run back over each other).
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2& a = ring[i];
    const Vec2& b = ring[(i + 1) % n];
    for (std::size_t j = i + 1; j < n; ++j) {
      const Vec2& c = ring[j];
      const Vec2& d = ring[(j + 1) % n];
      const bool next = j == i + 1, wraps = i == 0 && j == n - 1;
      if (next || wraps) {
        // Adjacent: a fold back along the shared line overlaps.
        const Vec2 shared = next ? b : a;
        const Vec2 u = (next ? a : b) - shared, v = (next ? d : c) - shared;
        if (Cross(u, v) == 0.0 && u.dot(v) > 0.0) {
          return absl::InvalidArgumentError(
              absl::StrCat(where, ": edges ", i, " and ", j, " fold back over each other"));
        }
        continue;
      }
      if (SegmentsMeet(a, b, c, d)) {
        return absl::InvalidArgumentError(absl::StrCat(where, ": edges ", i, " and ", j,
                                                       " cross or touch (not a simple polygon)"));
      }
    }
  }
  double twice_area = 0.0;
  for (std::size_t i = 0; i < n; ++i) twice_area += Cross(ring[i], ring[(i + 1) % n]);
  if (!(std::abs(twice_area) > 0.0)) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": encloses no area"));
  }
  if (twice_area < 0.0) std::reverse(ring.begin(), ring.end());
  return ring;
}

absl::StatusOr<Prism> Prism::Create(std::vector<Vec2> footprint_W, double base_m, double top_m,
                                    absl::string_view field) {
  const std::string where = absl::StrCat(field, ".footprint");
  absl::StatusOr<std::vector<Vec2>> simple = SimplePolygon(std::move(footprint_W), where);
  if (!simple.ok()) return simple.status();
  std::vector<Vec2> ring = *std::move(simple);
  if (!std::isfinite(base_m)) {
    return absl::InvalidArgumentError(absl::StrCat(field, ".base_m: must be finite"));
  }
  if (!std::isfinite(top_m) || !(top_m > base_m)) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ".top_m: must be finite and above base_m (", base_m, ")"));
  }
  Prism prism;
  prism.triangles_ = Triangulate(ring);
  if (prism.triangles_.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": too nearly degenerate to cut into triangles"));
  }
  for (const auto& t : prism.triangles_) {
    prism.triangle_bounds_.push_back(
        {t[0].cwiseMin(t[1]).cwiseMin(t[2]), t[0].cwiseMax(t[1]).cwiseMax(t[2])});
  }
  prism.lo_ = prism.hi_ = ring.front();
  for (const Vec2& v : ring) {
    prism.lo_ = prism.lo_.cwiseMin(v);
    prism.hi_ = prism.hi_.cwiseMax(v);
  }
  prism.footprint_ = std::move(ring);
  prism.base_m_ = base_m;
  prism.top_m_ = top_m;
  return prism;
}

double Prism::SignedDistance(const Vec3& p_W) const {
  return SignedDistanceAbove(PolygonSignedDistance(footprint_, p_W.head<2>()), p_W.z());
}

double Prism::SignedDistanceAbove(double footprint_distance, double z_m) const {
  return Combine(footprint_distance, std::max(base_m_ - z_m, z_m - top_m_));
}

Aabb Prism::BoundingBox() const {
  return {Vec3(lo_.x(), lo_.y(), base_m_), Vec3(hi_.x(), hi_.y(), top_m_)};
}

bool Prism::SegmentHits(const Vec3& a_W, const Vec3& b_W, double min_overlap) const {
  const Vec3 d = b_W - a_W;
  double z0 = 0.0, z1 = 1.0;
  ClipHalf(a_W.z() - base_m_, d.z(), z0, z1);
  ClipHalf(top_m_ - a_W.z(), -d.z(), z0, z1);
  if (z1 - z0 <= min_overlap) return false;
  // No allocation: this runs for every checked segment near a building.
  std::array<std::pair<double, double>, kMaxPrismVertices> intervals;
  std::size_t count = 0;
  for (const auto& t : triangles_) {
    double t0 = z0, t1 = z1;
    for (int k = 0; k < 3 && t0 < t1; ++k) {
      const Vec2 e = t[(k + 1) % 3] - t[k];
      // Cross(e, a + s d - v) >= 0, linear in s.
      ClipHalf(Cross(e, a_W.head<2>() - t[k]), Cross(e, d.head<2>()), t0, t1);
    }
    if (t1 > t0) intervals[count++] = {t0, t1};
  }
  const std::span<std::pair<double, double>> inside(intervals.data(), count);
  std::sort(inside.begin(), inside.end());
  // The union's longest run: neighbouring triangles' intervals meet.
  double run_start = 0.0, run_end = -1.0;
  for (const auto& [s, e] : inside) {
    if (s > run_end) {
      if (run_end - run_start > min_overlap) return true;
      run_start = s;
      run_end = e;
    } else {
      run_end = std::max(run_end, e);
    }
  }
  return run_end - run_start > min_overlap;
}

double Prism::SegmentSignedDistance(const Vec3& a_W, const Vec3& b_W) const {
  const Vec3 d = b_W - a_W;
  const Vec3 seg_lo = a_W.cwiseMin(b_W), seg_hi = a_W.cwiseMax(b_W);
  // Each triangle's prism at a lower bound (the gap between its box and the
  // segment's), nearest first, so that far triangles are never searched.
  // No allocation: this runs for every checked segment near a building.
  std::array<std::pair<double, std::size_t>, kMaxPrismVertices> bounds;
  for (std::size_t i = 0; i < triangles_.size(); ++i) {
    const auto& [lo2, hi2] = triangle_bounds_[i];
    const Vec3 lo(lo2.x(), lo2.y(), base_m_), hi(hi2.x(), hi2.y(), top_m_);
    const Vec3 gap = (lo - seg_hi).cwiseMax(seg_lo - hi).cwiseMax(0.0);
    bounds[i] = {gap.norm(), i};
  }
  const std::span<std::pair<double, std::size_t>> order(bounds.data(), triangles_.size());
  std::sort(order.begin(), order.end());
  double best = std::numeric_limits<double>::infinity();
  for (const auto& [bound, i] : order) {
    if (bound > 0.0 && bound >= best) break;
    const auto& t = triangles_[i];
    best = std::min(best, MinimumOfConvex(
                              [&](double s) {
                                const Vec3 p = a_W + s * d;
                                return Combine(TriangleSignedDistance(t, p.head<2>()),
                                               std::max(base_m_ - p.z(), p.z() - top_m_));
                              },
                              d.norm()));
  }
  return best;
}

}  // namespace oaipp
