#include "core/mapping/field_grid.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"

namespace oaipp {
namespace {

// Region tests accept centres this close outside the region (metres): a
// footprint edge that passes exactly through a row of centres must not split
// it by round-off.
constexpr double kEdgeTolerance_m = 1e-9;

// Clamps a real cell coordinate into [lo, hi] before converting to int, so
// that far-away (but finite) regions cannot overflow the conversion.
int ClampToInt(double v, int lo, int hi) {
  if (!(v > lo)) return lo;
  if (!(v < hi)) return hi;
  return static_cast<int>(v);
}

// Squared distance from p to the segment [a, b].
double SquaredDistanceToSegment(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).squaredNorm();
}

// Closed point-in-polygon test: on (or within kEdgeTolerance_m of) an edge
// counts as inside; otherwise the even-odd crossing rule.
bool InPolygon(const Vec2& p, std::span<const Vec2> poly) {
  const std::size_t n = poly.size();
  bool inside = false;
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    const Vec2& a = poly[i];
    const Vec2& b = poly[j];
    if (SquaredDistanceToSegment(p, a, b) <= kEdgeTolerance_m * kEdgeTolerance_m) return true;
    if ((a.y() > p.y()) != (b.y() > p.y())) {
      const double x_cross = a.x() + (p.y() - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
      if (p.x() < x_cross) inside = !inside;
    }
  }
  return inside;
}

// Area of the part of `polygon` inside the axis-aligned square [lo, hi]:
// Sutherland-Hodgman clipping against the square's four half-planes (exact
// for any simple polygon, since the square is convex; a concave polygon may
// leave zero-area bridges, which the shoelace sum ignores), then the
// shoelace formula.
double ClippedArea(std::span<const Vec2> polygon, const Vec2& lo, const Vec2& hi,
                   std::vector<Vec2>& scratch_a, std::vector<Vec2>& scratch_b) {
  scratch_a.assign(polygon.begin(), polygon.end());
  for (int side = 0; side < 4 && !scratch_a.empty(); ++side) {
    const int axis = side / 2;
    const bool upper = side % 2 == 1;
    const double bound = upper ? hi[axis] : lo[axis];
    const auto inside = [&](const Vec2& p) { return upper ? p[axis] <= bound : p[axis] >= bound; };
    scratch_b.clear();
    const std::size_t n = scratch_a.size();
    for (std::size_t i = 0; i < n; ++i) {
      const Vec2& a = scratch_a[i];
      const Vec2& b = scratch_a[(i + 1) % n];
      const bool a_in = inside(a);
      const bool b_in = inside(b);
      if (a_in) scratch_b.push_back(a);
      if (a_in != b_in) {
        const double t = (bound - a[axis]) / (b[axis] - a[axis]);
        Vec2 crossing = a + t * (b - a);
        crossing[axis] = bound;
        scratch_b.push_back(crossing);
      }
    }
    std::swap(scratch_a, scratch_b);
  }
  double twice_area = 0.0;
  const std::size_t n = scratch_a.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2& a = scratch_a[i];
    const Vec2& b = scratch_a[(i + 1) % n];
    twice_area += a.x() * b.y() - b.x() * a.y();
  }
  return 0.5 * std::abs(twice_area);
}

}  // namespace

absl::StatusOr<FieldGrid> FieldGrid::Create(const Vec2& origin_W, int nx, int ny,
                                            double resolution_m) {
  OAIPP_RETURN_IF_ERROR(CheckFinite("origin_W.x", origin_W.x()));
  OAIPP_RETURN_IF_ERROR(CheckFinite("origin_W.y", origin_W.y()));
  OAIPP_RETURN_IF_ERROR(CheckPositive("resolution_m", resolution_m));
  if (nx < 1) return absl::InvalidArgumentError(absl::StrCat("nx: must be >= 1, got ", nx));
  if (ny < 1) return absl::InvalidArgumentError(absl::StrCat("ny: must be >= 1, got ", ny));
  const std::int64_t n = static_cast<std::int64_t>(nx) * ny;
  if (n > kMaxCells) {
    return absl::ResourceExhaustedError(
        absl::StrCat("nx * ny: ", n, " cells exceed the limit of ", kMaxCells));
  }
  const Vec2 far_W = origin_W + resolution_m * Vec2(nx, ny);
  if (!AllFinite(far_W)) {
    return absl::InvalidArgumentError("origin_W + resolution_m * (nx, ny): must be finite");
  }
  return FieldGrid(origin_W, nx, ny, resolution_m);
}

absl::StatusOr<FieldGrid> FieldGrid::FromBounds(const Vec2& min_W, const Vec2& max_W,
                                                double resolution_m) {
  OAIPP_RETURN_IF_ERROR(CheckFinite("min_W.x", min_W.x()));
  OAIPP_RETURN_IF_ERROR(CheckFinite("min_W.y", min_W.y()));
  OAIPP_RETURN_IF_ERROR(CheckFinite("max_W.x", max_W.x()));
  OAIPP_RETURN_IF_ERROR(CheckFinite("max_W.y", max_W.y()));
  OAIPP_RETURN_IF_ERROR(CheckPositive("resolution_m", resolution_m));
  int counts[2] = {0, 0};
  for (int axis = 0; axis < 2; ++axis) {
    const char* name = axis == 0 ? "x" : "y";
    const double extent_m = max_W[axis] - min_W[axis];
    if (!(extent_m > 0.0)) {
      return absl::InvalidArgumentError(absl::StrCat("max_W.", name, ": must exceed min_W.", name,
                                                     ", got ", max_W[axis], " <= ", min_W[axis]));
    }
    const double cells = extent_m / resolution_m;
    if (!(cells < static_cast<double>(kMaxCells) + 1.0)) {
      return absl::ResourceExhaustedError(absl::StrCat("max_W.", name, " - min_W.", name, ": ",
                                                       cells, " cells exceed the limit of ",
                                                       kMaxCells));
    }
    const double rounded = std::round(cells);
    if (rounded < 1.0 || std::abs(cells - rounded) > 1e-6 * rounded) {
      return absl::InvalidArgumentError(
          absl::StrCat("resolution_m: the field extent along ", name, " (", extent_m,
                       " m) is not a whole number of ", resolution_m, " m cells"));
    }
    counts[axis] = static_cast<int>(rounded);
  }
  return Create(min_W, counts[0], counts[1], resolution_m);
}

Vec2 FieldGrid::CellCentreXY(int index) const {
  return origin_W_ + resolution_m_ * Vec2(Col(index) + 0.5, Row(index) + 0.5);
}

Vec3 FieldGrid::CellCentre(int index) const {
  const Vec2 c = CellCentreXY(index);
  return Vec3(c.x(), c.y(), 0.0);
}

std::optional<int> FieldGrid::CellOf(const Vec2& p_W) const {
  if (!AllFinite(p_W)) return std::nullopt;
  const Vec2 q = (p_W - origin_W_) / resolution_m_;
  if (q.x() < 0.0 || q.y() < 0.0 || q.x() > nx_ || q.y() > ny_) return std::nullopt;
  const int col = std::min(static_cast<int>(q.x()), nx_ - 1);
  const int row = std::min(static_cast<int>(q.y()), ny_ - 1);
  return Index(row, col);
}

template <typename Inside>
std::vector<int> FieldGrid::CellsInBox(const Vec2& lo_W, const Vec2& hi_W, Inside inside) const {
  std::vector<int> cells;
  if (!AllFinite(lo_W) || !AllFinite(hi_W)) return cells;
  // Centre of column c is x0 + (c + 0.5) r: the columns with centres in
  // [lo, hi] are ceil((lo - x0) / r - 0.5) .. floor((hi - x0) / r - 0.5).
  const Vec2 lo = (lo_W.array() - kEdgeTolerance_m - origin_W_.array()) / resolution_m_ - 0.5;
  const Vec2 hi = (hi_W.array() + kEdgeTolerance_m - origin_W_.array()) / resolution_m_ - 0.5;
  const int col_lo = ClampToInt(std::ceil(lo.x()), 0, nx_);
  const int col_hi = ClampToInt(std::floor(hi.x()), -1, nx_ - 1);
  const int row_lo = ClampToInt(std::ceil(lo.y()), 0, ny_);
  const int row_hi = ClampToInt(std::floor(hi.y()), -1, ny_ - 1);
  for (int row = row_lo; row <= row_hi; ++row) {
    for (int col = col_lo; col <= col_hi; ++col) {
      const int index = Index(row, col);
      if (inside(CellCentreXY(index))) cells.push_back(index);
    }
  }
  return cells;
}

std::vector<int> FieldGrid::CellsInRectangle(const Vec2& centre_W, const Vec2& size_m,
                                             double yaw_rad) const {
  if (!AllFinite(centre_W) || !AllFinite(size_m) || !std::isfinite(yaw_rad) ||
      (size_m.array() < 0.0).any()) {
    return {};
  }
  const double c = std::cos(yaw_rad);
  const double s = std::sin(yaw_rad);
  const Vec2 half = 0.5 * size_m;
  // Half-extents of the rotated rectangle's axis-aligned bounding box.
  const Vec2 reach(std::abs(c) * half.x() + std::abs(s) * half.y(),
                   std::abs(s) * half.x() + std::abs(c) * half.y());
  return CellsInBox(centre_W - reach, centre_W + reach, [&](const Vec2& p_W) {
    const Vec2 d = p_W - centre_W;
    const double along_x = c * d.x() + s * d.y();
    const double along_y = -s * d.x() + c * d.y();
    return std::abs(along_x) <= half.x() + kEdgeTolerance_m &&
           std::abs(along_y) <= half.y() + kEdgeTolerance_m;
  });
}

std::vector<int> FieldGrid::CellsInPolygon(std::span<const Vec2> polygon_W) const {
  if (polygon_W.size() < 3) return {};
  Vec2 lo = polygon_W[0];
  Vec2 hi = polygon_W[0];
  for (const Vec2& v : polygon_W) {
    if (!AllFinite(v)) return {};
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  return CellsInBox(lo, hi, [&](const Vec2& p_W) { return InPolygon(p_W, polygon_W); });
}

std::vector<int> FieldGrid::CellsOverlapping(const Vec2& min_W, const Vec2& max_W) const {
  std::vector<int> cells;
  if (!AllFinite(min_W) || !AllFinite(max_W) || (max_W.array() <= min_W.array()).any()) {
    return cells;
  }
  // Column c spans [x0 + c r, x0 + (c + 1) r]; it overlaps [min, max] with
  // positive area when x0 + (c + 1) r > min and x0 + c r < max. Overlaps
  // thinner than kEdgeTolerance_m are round-off of edges that coincide.
  const Vec2 lo = (min_W.array() + kEdgeTolerance_m - origin_W_.array()) / resolution_m_;
  const Vec2 hi = (max_W.array() - kEdgeTolerance_m - origin_W_.array()) / resolution_m_;
  const int col_lo = ClampToInt(std::floor(lo.x()), 0, nx_);
  const int col_hi = ClampToInt(std::ceil(hi.x()) - 1.0, -1, nx_ - 1);
  const int row_lo = ClampToInt(std::floor(lo.y()), 0, ny_);
  const int row_hi = ClampToInt(std::ceil(hi.y()) - 1.0, -1, ny_ - 1);
  for (int row = row_lo; row <= row_hi; ++row) {
    for (int col = col_lo; col <= col_hi; ++col) cells.push_back(Index(row, col));
  }
  return cells;
}

std::vector<int> FieldGrid::CellsOverlappingPolygon(std::span<const Vec2> polygon_W,
                                                    double min_area_m2) const {
  std::vector<int> cells;
  if (polygon_W.size() < 3) return cells;
  Vec2 lo = polygon_W[0];
  Vec2 hi = polygon_W[0];
  for (const Vec2& v : polygon_W) {
    if (!AllFinite(v)) return cells;
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  if ((hi.array() <= lo.array()).any()) return cells;
  std::vector<Vec2> scratch_a, scratch_b;
  // Candidates: the cells overlapping the polygon's bounding box.
  for (int cell : CellsOverlapping(lo, hi)) {
    const Vec2 cell_lo = origin_W_ + resolution_m_ * Vec2(Col(cell), Row(cell));
    const Vec2 cell_hi = cell_lo + Vec2::Constant(resolution_m_);
    if (ClippedArea(polygon_W, cell_lo, cell_hi, scratch_a, scratch_b) > min_area_m2) {
      cells.push_back(cell);
    }
  }
  return cells;
}

std::vector<int> FieldGrid::CellsUnderObstacles(
    const std::function<bool(const Vec3& p_W)>& inside_obstacle) const {
  std::vector<int> cells;
  for (int c = 0; c < num_cells(); ++c) {
    if (inside_obstacle(CellCentre(c) + Vec3(0, 0, 1e-3))) cells.push_back(c);
  }
  return cells;
}

}  // namespace oaipp
