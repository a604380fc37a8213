// The SAREnv benchmark's scores of a set of drone paths over a SearchArea:
// likelihood (probability seen at all), time-discounted score
// (probability seen, earlier counting more), victims found (%) and area
// covered (km^2), plus the polyline operations they and the planners share
// (length, a point at a distance, a piece between two distances).
//
//   std::vector<Polyline> paths = ...;  // one per drone, in the area's CRS metres
//   std::vector<PointXY> victims = DrawVictims(area, 100, /*seed=*/1001);
//   absl::StatusOr<PathMetrics> m = EvaluatePaths(area, paths, victims);
//   if (m.ok()) std::printf("%.6f %.3f km2\n", m->likelihood, m->area_covered_km2);
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "client/sarenv/dataset.h"

namespace oaipp::sarenv {

struct PointXY {
  double x_m = 0;
  double y_m = 0;
};
using Polyline = std::vector<PointXY>;

// Sum of the segments' lengths.
[[nodiscard]] double PolylineLength_m(const Polyline& line);

// The point `distance_m` along the line, clamped to its ends; a line
// without points gives (0, 0). Walks the segments as GEOS's linear
// referencing does (the first segment whose running length passes the
// distance), so that sample points match the benchmark's to the last bit.
[[nodiscard]] PointXY PointAlong(const Polyline& line, double distance_m);

// The piece of `line` from start_m to end_m (0 <= start_m < end_m): the
// points at both distances and every vertex strictly between them, as
// shapely's substring builds it. Empty when start_m >= end_m or the line
// is shorter than start_m.
[[nodiscard]] Polyline Substring(const Polyline& line, double start_m, double end_m);

// The line itself when it is at most max_length_m long, else its first
// max_length_m.
[[nodiscard]] Polyline CutToLength(const Polyline& line, double max_length_m);

// Each drone's path cut to budget_m / paths.size() (the budget is the
// total for all drones); budget_m <= 0 leaves them as they are.
[[nodiscard]] std::vector<Polyline> CutToBudget(std::vector<Polyline> paths, double budget_m);

struct MetricsOptions {
  double altitude_m = 80.0;
  double fov_deg = 45.0;
  double discount_per_m = 0.999;  // a sample's weight is discount_per_m ^ (metres flown)
  // Spacing of the samples along a path; 0: ceil(meter_per_bin / 2) of
  // the area (15 m for SAREnv's 30 m cells), as the benchmark has it.
  double sample_spacing_m = 0.0;
  int buffer_quadrant_segments = 16;  // shapely's default resolution
};

// Ground radius seen from altitude_m with a camera of fov_deg:
// altitude tan(fov / 2); 33.137 m for 80 m and 45 deg.
[[nodiscard]] double DetectionRadius_m(const MetricsOptions& options);

// Row-major indices (row * cols + col) of the cells of `area` whose centres
// lie within radius_m of `p` (distance <= radius), in increasing order.
[[nodiscard]] std::vector<int64_t> VisibleCells(const SearchArea& area, double radius_m, PointXY p);

// The sample points of one path: ceil(length / spacing) + 1 points evenly
// spread over its length (so never more than `spacing` apart), both ends
// included; none for a path of zero length.
[[nodiscard]] std::vector<PointXY> SamplePath(const Polyline& line, double spacing_m);

struct MapScores {
  double likelihood = 0;       // map summed over the cells seen from any sample
  double time_discounted = 0;  // per sample: map over its cells x discount^distance
};

// The two map-based scores. Drones are counted one after the other: drone
// k's distances start at the summed lengths of drones 0..k-1.
[[nodiscard]] MapScores ScoreOnMap(const SearchArea& area, const std::vector<Polyline>& paths,
                                   const MetricsOptions& options = {});

struct Coverage {
  double area_m2 = 0;          // of the union of the buffered paths
  int64_t victims_inside = 0;  // victims in its interior
};

// Buffers every path of positive length by radius_m (round caps and joins,
// `quadrant_segments` segments per quarter circle), unites them with GEOS
// and measures the union; Internal when GEOS fails.
[[nodiscard]] absl::StatusOr<Coverage> BufferedCoverage(const std::vector<Polyline>& paths,
                                                        double radius_m,
                                                        const std::vector<PointXY>& victims,
                                                        int quadrant_segments = 16);

struct PathMetrics {
  double likelihood = 0;
  double time_discounted = 0;
  double victims_found_pct = 0;  // 0 when there are no victims
  double area_covered_km2 = 0;   // not clipped to the disc
  double total_path_length_km = 0;
};

// All the scores of `paths` (as given: cut them with CutToBudget first).
[[nodiscard]] absl::StatusOr<PathMetrics> EvaluatePaths(const SearchArea& area,
                                                        const std::vector<Polyline>& paths,
                                                        const std::vector<PointXY>& victims,
                                                        const MetricsOptions& options = {});

// `count` victims drawn independently from the area's map: a cell with
// probability proportional to its value, then a uniform point in that cell
// (the SearchArea's grid). std::mt19937_64(seed) drives it; its raw 64-bit
// outputs are turned into uniforms by this code, not by <random>'s
// distributions, so that every standard library draws the same victims.
// None when the map sums to 0.
[[nodiscard]] std::vector<PointXY> DrawVictims(const SearchArea& area, int count, uint64_t seed);

}  // namespace oaipp::sarenv
