#include "client/sarenv/metrics.h"

#include <geos_c.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <random>
#include <string>

#include "absl/strings/str_cat.h"
#include "api/geos_context.h"

namespace oaipp::sarenv {
namespace {

double SegmentLength(const PointXY& a, const PointXY& b) {
  const double dx = b.x_m - a.x_m;
  const double dy = b.y_m - a.y_m;
  return std::sqrt(dx * dx + dy * dy);
}

PointXY Lerp(const PointXY& a, const PointXY& b, double fraction) {
  if (fraction <= 0) return a;
  if (fraction >= 1) return b;
  return {a.x_m + fraction * (b.x_m - a.x_m), a.y_m + fraction * (b.y_m - a.y_m)};
}

// Walks a line forward for distances given in increasing order. It keeps
// the same running total that a walk from the start would, so each answer
// equals PointAlong's bit for bit while costing one pass for all samples.
class ForwardWalker {
 public:
  explicit ForwardWalker(const Polyline& line) : line_(line) {}

  PointXY At(double distance_m) {
    if (line_.empty()) return {};
    if (distance_m <= 0) return line_.front();
    while (segment_ + 1 < line_.size()) {
      const double length = SegmentLength(line_[segment_], line_[segment_ + 1]);
      if (walked_ + length > distance_m) {
        return Lerp(line_[segment_], line_[segment_ + 1], (distance_m - walked_) / length);
      }
      walked_ += length;
      ++segment_;
    }
    return line_.back();
  }

 private:
  const Polyline& line_;
  size_t segment_ = 0;
  double walked_ = 0;  // length of the segments before segment_
};

double SampleSpacing_m(const SearchArea& area, const MetricsOptions& options) {
  return options.sample_spacing_m > 0 ? options.sample_spacing_m
                                      : std::ceil(area.meter_per_bin / 2);
}

// The sample distances along a path of length_m: linspace(0, length, n)
// as NumPy computes it (i * step, the last one exactly length_m).
std::vector<double> SampleDistances(double length_m, double spacing_m) {
  if (!(length_m > 0) || !(spacing_m > 0)) return {};
  const auto count = static_cast<int64_t>(std::ceil(length_m / spacing_m)) + 1;
  const double step = length_m / static_cast<double>(count - 1);
  std::vector<double> distances(count);
  for (int64_t i = 0; i < count; ++i) distances[i] = static_cast<double>(i) * step;
  distances.back() = length_m;
  return distances;
}

template <typename Visit>
void ForEachVisibleCell(const SearchArea& area, double radius_m, PointXY p, Visit visit) {
  const Grid2D& map = area.heatmap;
  const double size_x = area.CellSizeX_m();
  const double size_y = area.CellSizeY_m();
  const auto reach_x = static_cast<int64_t>(std::ceil(radius_m / size_x));
  const auto reach_y = static_cast<int64_t>(std::ceil(radius_m / size_y));
  if (!std::isfinite(p.x_m) || !std::isfinite(p.y_m)) return;
  // Truncation toward zero, like Python's int(); a point just west or south
  // of the map then still looks at the first column or row. (Clamped first:
  // casting a double beyond int64's range is undefined.)
  const auto index = [](double v) { return static_cast<int64_t>(std::clamp(v, -0x1p40, 0x1p40)); };
  const int64_t col = index(std::trunc((p.x_m - area.bounds.min_x_m) / size_x));
  const int64_t row = index(std::trunc((p.y_m - area.bounds.min_y_m) / size_y));
  for (int64_t r = std::max<int64_t>(0, row - reach_y); r < std::min(map.rows, row + reach_y + 1);
       ++r) {
    const double cy = area.bounds.min_y_m + (static_cast<double>(r) + 0.5) * size_y;
    for (int64_t c = std::max<int64_t>(0, col - reach_x); c < std::min(map.cols, col + reach_x + 1);
         ++c) {
      const double cx = area.bounds.min_x_m + (static_cast<double>(c) + 0.5) * size_x;
      const double dx = cx - p.x_m;
      const double dy = cy - p.y_m;
      if (std::sqrt(dx * dx + dy * dy) <= radius_m) visit(r * map.cols + c);
    }
  }
}

// A GEOS context (api/geos_context.h) that builds the paths' lines.
class Geos : public api::GeosContext {
 public:
  absl::StatusOr<Ptr> LineString(const Polyline& line) const {
    GEOSCoordSequence* seq = GEOSCoordSeq_create_r(ctx(), static_cast<unsigned>(line.size()), 2);
    if (seq == nullptr) return Failure("coordinate sequence");
    for (size_t i = 0; i < line.size(); ++i) {
      if (GEOSCoordSeq_setXY_r(ctx(), seq, static_cast<unsigned>(i), line[i].x_m, line[i].y_m) ==
          0) {
        GEOSCoordSeq_destroy_r(ctx(), seq);
        return Failure("coordinate");
      }
    }
    GEOSGeometry* g = GEOSGeom_createLineString_r(ctx(), seq);  // takes seq
    if (g == nullptr) return Failure("line string");
    return Own(g);
  }
};

// A uniform double in [0, 1) from the top 53 bits of one draw.
double Uniform01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

}  // namespace

double PolylineLength_m(const Polyline& line) {
  double length = 0;
  for (size_t i = 1; i < line.size(); ++i) length += SegmentLength(line[i - 1], line[i]);
  return length;
}

PointXY PointAlong(const Polyline& line, double distance_m) {
  return ForwardWalker(line).At(distance_m);
}

Polyline Substring(const Polyline& line, double start_m, double end_m) {
  if (line.size() < 2 || !(start_m < end_m)) return {};
  const double length = PolylineLength_m(line);
  if (start_m >= length) return {};
  start_m = std::max(start_m, 0.0);
  Polyline out{PointAlong(line, start_m)};
  // Vertices strictly inside (start, end), located by the running sum of
  // the segment lengths before them.
  double at = 0;
  for (size_t i = 0; i + 1 < line.size(); ++i) {
    if (at >= end_m) break;
    if (start_m < at) out.push_back(line[i]);
    at += SegmentLength(line[i], line[i + 1]);
  }
  out.push_back(PointAlong(line, end_m));
  return out;
}

Polyline CutToLength(const Polyline& line, double max_length_m) {
  if (line.size() < 2 || PolylineLength_m(line) <= max_length_m) return line;
  return Substring(line, 0, max_length_m);
}

std::vector<Polyline> CutToBudget(std::vector<Polyline> paths, double budget_m) {
  if (budget_m <= 0 || paths.empty()) return paths;
  const double per_drone = budget_m / static_cast<double>(paths.size());
  for (Polyline& path : paths) path = CutToLength(path, per_drone);
  return paths;
}

double DetectionRadius_m(const MetricsOptions& options) {
  return options.altitude_m * std::tan(options.fov_deg / 2 * (std::numbers::pi / 180.0));
}

std::vector<int64_t> VisibleCells(const SearchArea& area, double radius_m, PointXY p) {
  std::vector<int64_t> cells;
  ForEachVisibleCell(area, radius_m, p, [&](int64_t cell) { cells.push_back(cell); });
  return cells;
}

std::vector<PointXY> SamplePath(const Polyline& line, double spacing_m) {
  std::vector<PointXY> points;
  ForwardWalker walker(line);
  for (const double d : SampleDistances(PolylineLength_m(line), spacing_m)) {
    points.push_back(walker.At(d));
  }
  return points;
}

MapScores ScoreOnMap(const SearchArea& area, const std::vector<Polyline>& paths,
                     const MetricsOptions& options) {
  const double radius = DetectionRadius_m(options);
  const double spacing = SampleSpacing_m(area, options);
  const std::vector<double>& map = area.heatmap.values;
  std::vector<char> seen(map.size(), 0);
  MapScores scores;
  double flown_before = 0;  // by the drones counted so far
  for (const Polyline& path : paths) {
    const double length = PolylineLength_m(path);
    if (!(length > 0)) continue;
    ForwardWalker walker(path);
    for (const double d : SampleDistances(length, spacing)) {
      double seen_here = 0;
      ForEachVisibleCell(area, radius, walker.At(d), [&](int64_t cell) {
        seen_here += map[cell];
        seen[cell] = 1;
      });
      scores.time_discounted += seen_here * std::pow(options.discount_per_m, d + flown_before);
    }
    flown_before += length;
  }
  for (size_t cell = 0; cell < map.size(); ++cell) {
    if (seen[cell]) scores.likelihood += map[cell];
  }
  return scores;
}

absl::StatusOr<Coverage> BufferedCoverage(const std::vector<Polyline>& paths, double radius_m,
                                          const std::vector<PointXY>& victims,
                                          int quadrant_segments) {
  Coverage coverage;
  const Geos geos;
  GEOSContextHandle_t ctx = geos.ctx();
  std::vector<Geos::Ptr> buffers;
  for (const Polyline& path : paths) {
    if (!(PolylineLength_m(path) > 0)) continue;
    absl::StatusOr<Geos::Ptr> line = geos.LineString(path);
    if (!line.ok()) return line.status();
    GEOSGeometry* buffer = GEOSBuffer_r(ctx, line->get(), radius_m, quadrant_segments);
    if (buffer == nullptr) return geos.Failure("buffer");
    buffers.push_back(geos.Own(buffer));
  }
  if (buffers.empty()) return coverage;
  absl::StatusOr<Geos::Ptr> union_owner = geos.UnionOf(std::move(buffers));
  if (!union_owner.ok()) return union_owner.status();
  const GEOSGeometry* united = union_owner->get();
  if (GEOSArea_r(ctx, united, &coverage.area_m2) == 0) return geos.Failure("area");
  if (victims.empty()) return coverage;

  const Geos::PreparedPtr prepared = geos.Prepare(united);
  if (prepared == nullptr) return geos.Failure("prepare");
  for (const PointXY& v : victims) {
    const Geos::Ptr point = geos.Own(GEOSGeom_createPointFromXY_r(ctx, v.x_m, v.y_m));
    if (point == nullptr) return geos.Failure("point");
    // Contains: the interior only, as "victim within the covered area" is.
    const char inside = GEOSPreparedContains_r(ctx, prepared.get(), point.get());
    if (inside == 2) return geos.Failure("contains");
    coverage.victims_inside += inside;
  }
  return coverage;
}

absl::StatusOr<PathMetrics> EvaluatePaths(const SearchArea& area,
                                          const std::vector<Polyline>& paths,
                                          const std::vector<PointXY>& victims,
                                          const MetricsOptions& options) {
  const MapScores scores = ScoreOnMap(area, paths, options);
  absl::StatusOr<Coverage> coverage = BufferedCoverage(paths, DetectionRadius_m(options), victims,
                                                       options.buffer_quadrant_segments);
  if (!coverage.ok()) return coverage.status();
  PathMetrics out{.likelihood = scores.likelihood,
                  .time_discounted = scores.time_discounted,
                  .victims_found_pct = 0,
                  .area_covered_km2 = coverage->area_m2 / 1e6,
                  .total_path_length_km = 0};
  if (!victims.empty()) {
    out.victims_found_pct =
        100.0 * static_cast<double>(coverage->victims_inside) / static_cast<double>(victims.size());
  }
  for (const Polyline& path : paths) {
    const double length = PolylineLength_m(path);
    if (length > 0) out.total_path_length_km += length / 1000;
  }
  return out;
}

std::vector<PointXY> DrawVictims(const SearchArea& area, int count, uint64_t seed) {
  const std::vector<double>& map = area.heatmap.values;
  std::vector<double> cumulative(map.size());
  double total = 0;
  int64_t last_positive = -1;
  for (size_t i = 0; i < map.size(); ++i) {
    if (map[i] > 0) {
      total += map[i];
      last_positive = static_cast<int64_t>(i);
    }
    cumulative[i] = total;
  }
  std::vector<PointXY> victims;
  if (!(total > 0) || count <= 0) return victims;
  std::mt19937_64 rng(seed);
  const double size_x = area.CellSizeX_m();
  const double size_y = area.CellSizeY_m();
  for (int k = 0; k < count; ++k) {
    const double u = Uniform01(rng) * total;
    // The first cell whose running sum passes u: cells of value 0 add
    // nothing to the sum and so are never drawn.
    auto cell = static_cast<int64_t>(std::upper_bound(cumulative.begin(), cumulative.end(), u) -
                                     cumulative.begin());
    if (cell >= static_cast<int64_t>(map.size())) cell = last_positive;  // u rounded up to total
    const int64_t row = cell / area.heatmap.cols;
    const int64_t col = cell % area.heatmap.cols;
    const double fx = Uniform01(rng);
    const double fy = Uniform01(rng);
    victims.push_back({area.bounds.min_x_m + (static_cast<double>(col) + fx) * size_x,
                       area.bounds.min_y_m + (static_cast<double>(row) + fy) * size_y});
  }
  return victims;
}

}  // namespace oaipp::sarenv
