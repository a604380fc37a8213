#include "client/sarenv/baselines.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <random>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"

namespace oaipp::sarenv {
namespace {

constexpr double kPi = std::numbers::pi;

// NumPy's linspace as it computes it: start + i * ((stop - start) / (num -
// 1)), the last value exactly `stop`. Its rounding decides where the
// published paths' vertices are, so it is kept rather than a nicer form.
std::vector<double> Linspace(double start, double stop, int64_t num) {
  if (num <= 1) return num == 1 ? std::vector<double>{start} : std::vector<double>{};
  const double step = (stop - start) / static_cast<double>(num - 1);
  std::vector<double> out(num);
  for (int64_t i = 0; i < num; ++i) out[i] = static_cast<double>(i) * step + start;
  out.back() = stop;
  return out;
}

double SweepSpacing_m(const BaselineOptions& o) {
  return 2 * o.altitude_m * std::tan(o.fov_deg / 2 * (kPi / 180.0)) * (1 - o.overlap);
}

void AppendArc(Polyline& out, double cx, double cy, double radius, const std::vector<double>& th) {
  for (const double t : th) out.push_back({cx + radius * std::cos(t), cy + radius * std::sin(t)});
}

// One long path shared by n drones: drone k flies the k-th of n pieces of
// equal length, each then cut to its share of the budget.
std::vector<Polyline> ShareOut(const Polyline& path, int n, double per_drone_m) {
  std::vector<Polyline> pieces;
  if (n <= 1) {
    pieces.push_back(path);
  } else {
    const double piece = PolylineLength_m(path) / n;
    for (int k = 0; k < n; ++k) pieces.push_back(Substring(path, k * piece, (k + 1) * piece));
  }
  for (Polyline& p : pieces) p = CutToLength(p, per_drone_m);
  return pieces;
}

Polyline SpiralPath(const SearchArea& area, const BaselineOptions& o) {
  const double spacing = SweepSpacing_m(o);
  const double a = spacing / (2 * kPi);  // radius grows by `spacing` per turn
  const double theta_max = area.radius_m / spacing * 2 * kPi;
  // Arc length of r = a theta from 0 to theta_max; it only sets how many
  // points the spiral gets (about one per point_spacing_m).
  const double root = std::sqrt(1 + theta_max * theta_max);
  const double length = 0.5 * a * (theta_max * root + std::log(theta_max + root));
  const auto count = static_cast<int64_t>(length / o.point_spacing_m);
  Polyline path;
  for (const double t : Linspace(0, theta_max, std::max<int64_t>(2, count))) {
    const double r = std::clamp(a * t, 0.0, area.radius_m);
    path.push_back({area.center_x_m + r * std::cos(t), area.center_y_m + r * std::sin(t)});
  }
  return path;
}

Polyline ConcentricPath(const SearchArea& area, const BaselineOptions& o) {
  const double step = SweepSpacing_m(o);
  const double cx = area.center_x_m;
  const double cy = area.center_y_m;
  Polyline path;
  for (double r = step; r <= area.radius_m;) {
    // Each circle stops short of closing by transition_m of arc; the drone
    // then moves straight out to the next circle's start on the +x axis.
    const double gap = o.transition_m / r;
    const double open_end = 2 * kPi - gap;
    const auto count = static_cast<int64_t>(r * open_end / o.point_spacing_m);
    AppendArc(path, cx, cy, r, Linspace(0, open_end, std::max<int64_t>(2, count)));
    const double next = r + step;
    if (next <= area.radius_m) {
      path.push_back({cx + next, cy});
    } else {  // the last circle is closed instead
      const auto rest = static_cast<int64_t>(r * gap / o.point_spacing_m);
      AppendArc(path, cx, cy, r, Linspace(open_end, 2 * kPi, std::max<int64_t>(2, rest)));
    }
    r = next;
  }
  return path;
}

std::vector<Polyline> PizzaPaths(const SearchArea& area, int n, const BaselineOptions& o) {
  const double width = SweepSpacing_m(o);
  const double sector = 2 * kPi / n;
  std::vector<Polyline> paths;
  for (int k = 0; k < n; ++k) {
    // Sector k spans angles [k, k + 1) x sector, counter-clockwise from +x.
    Polyline path{{area.center_x_m, area.center_y_m}};
    bool counter_clockwise = true;
    for (double r = width; r <= area.radius_m; r += width) {
      const double margin = o.border_gap_m / r;
      const double from = k * sector + margin;
      const double to = (k + 1) * sector - margin;
      if (from >= to) continue;  // too close to the centre for an arc
      const auto count =
          std::max<int64_t>(2, static_cast<int64_t>(r * (to - from) / o.point_spacing_m));
      AppendArc(path, area.center_x_m, area.center_y_m, r,
                counter_clockwise ? Linspace(from, to, count) : Linspace(to, from, count));
      counter_clockwise = !counter_clockwise;
    }
    paths.push_back(path.size() > 1 ? path : Polyline{});
  }
  return paths;
}

// A uniform integer in [0, k), by rejection so that it is unbiased and the
// same with every standard library.
uint64_t UniformIndex(std::mt19937_64& rng, uint64_t k) {
  const uint64_t reject_below = (0 - k) % k;  // 2^64 mod k
  for (;;) {
    const uint64_t x = rng();
    if (x >= reject_below) return x % k;
  }
}

// Python's a // b for the positive floats the budget arithmetic uses.
double FloorDiv(double a, double b) {
  const double mod = std::fmod(a, b);
  return std::floor((a - mod) / b);
}

std::vector<Polyline> GreedyPaths(const SearchArea& area, const Grid2D& map, int n, double budget_m,
                                  const BaselineOptions& o, uint64_t seed) {
  std::mt19937_64 rng(seed);
  const int64_t rows = map.rows;
  const int64_t cols = map.cols;
  const double dx = area.CellSizeX_m();
  const double dy = area.CellSizeY_m();
  const double x0 = area.bounds.min_x_m + dx / 2;  // centre of column 0
  const double y0 = area.bounds.min_y_m + dy / 2;
  const double radius = o.altitude_m * std::tan(o.fov_deg / 2 * (kPi / 180.0));
  const auto reach_x = static_cast<int64_t>(std::ceil(radius / dx));
  const auto reach_y = static_cast<int64_t>(std::ceil(radius / dy));
  std::vector<char> observed(map.values.size(), 0);

  // Calls visit(cell) for every cell whose centre is within the sensor's
  // radius of cell (row, col)'s centre.
  const auto for_each_seen = [&](int64_t row, int64_t col, auto visit) {
    const double px = x0 + col * dx;
    const double py = y0 + row * dy;
    for (int64_t r = std::max<int64_t>(0, row - reach_y); r < std::min(rows, row + reach_y + 1);
         ++r) {
      for (int64_t c = std::max<int64_t>(0, col - reach_x); c < std::min(cols, col + reach_x + 1);
           ++c) {
        const double ex = x0 + c * dx - px;
        const double ey = y0 + r * dy - py;
        if (std::sqrt(ex * ex + ey * ey) <= radius) visit(r * cols + c);
      }
    }
  };
  const auto observe = [&](int64_t row, int64_t col) {
    for_each_seen(row, col, [&](int64_t cell) { observed[cell] = 1; });
  };
  const auto gain = [&](int64_t row, int64_t col) {
    double sum = 0;
    for_each_seen(row, col, [&](int64_t cell) {
      if (!observed[cell]) sum += map.values[cell];
    });
    return sum;
  };

  // Drone 0 starts in the centre's cell, drone k > 0 about two cells away
  // from it at the angle 2 pi k / n.
  const auto start_index = [](double v, int64_t size) {
    return static_cast<int64_t>(std::trunc(std::clamp(v, 0.0, static_cast<double>(size - 1))));
  };
  const int64_t start_row = start_index((area.center_y_m - area.bounds.min_y_m) / dy, rows);
  const int64_t start_col = start_index((area.center_x_m - area.bounds.min_x_m) / dx, cols);
  std::vector<std::vector<std::array<int64_t, 2>>> cells(n);
  for (int k = 0; k < n; ++k) {
    int64_t r = start_row;
    int64_t c = start_col;
    if (k > 0) {
      const double angle = 2 * kPi * k / n;
      const int64_t offset_r = std::min<int64_t>(2, rows / 10);
      const int64_t offset_c = std::min<int64_t>(2, cols / 10);
      r = std::clamp<int64_t>(r + static_cast<int64_t>(std::trunc(offset_r * std::sin(angle))), 0,
                              rows - 1);
      c = std::clamp<int64_t>(c + static_cast<int64_t>(std::trunc(offset_c * std::cos(angle))), 0,
                              cols - 1);
    }
    cells[k].push_back({r, c});
    observe(r, c);
  }

  // Every step is at least one cell long, so this many steps per drone
  // always exhaust the budget.
  const double steps = FloorDiv(FloorDiv(budget_m, dx), n);
  static constexpr int kMoves[8][2] = {{-1, -1}, {-1, 0}, {-1, 1}, {0, -1},
                                       {0, 1},   {1, -1}, {1, 0},  {1, 1}};
  const double max_r2 = area.radius_m * area.radius_m;
  for (double step = 0; step < steps; ++step) {
    for (int k = 0; k < n; ++k) {
      const auto [row, col] = cells[k].back();
      // Valid moves in kMoves order, and those of the largest gain.
      std::array<std::array<int64_t, 2>, 8> valid{};
      std::array<std::array<int64_t, 2>, 8> best{};
      int n_valid = 0;
      int n_best = 0;
      double best_gain = 0;
      for (const auto& move : kMoves) {
        const int64_t r = row + move[0];
        const int64_t c = col + move[1];
        if (r < 0 || r >= rows || c < 0 || c >= cols) continue;
        const double ex = x0 + c * dx - area.center_x_m;
        const double ey = y0 + r * dy - area.center_y_m;
        if (ex * ex + ey * ey >= max_r2) continue;  // stay inside the disc
        const double g = gain(r, c);
        if (n_valid == 0 || g > best_gain) {
          best_gain = g;
          n_best = 0;
        }
        if (g == best_gain) best[n_best++] = {r, c};
        valid[n_valid++] = {r, c};
      }
      if (n_valid == 0) continue;  // boxed in: the drone waits
      std::array<int64_t, 2> next = best[0];
      if (!(best_gain > 0)) {
        // Nothing new in sight anywhere: a random step.
        next = valid[UniformIndex(rng, n_valid)];
      } else if (o.greedy_random_ties && n_best > 1) {
        next = best[UniformIndex(rng, n_best)];
      }
      cells[k].push_back(next);
      observe(next[0], next[1]);
    }
  }

  std::vector<Polyline> paths(n);
  const double per_drone = budget_m / n;
  for (int k = 0; k < n; ++k) {
    if (cells[k].size() < 2) continue;
    for (const auto& [r, c] : cells[k]) paths[k].push_back({x0 + c * dx, y0 + r * dy});
    paths[k] = CutToLength(paths[k], per_drone);
  }
  return paths;
}

}  // namespace

absl::string_view BaselineName(Baseline baseline) {
  switch (baseline) {
    case Baseline::kSpiral:
      return "Spiral";
    case Baseline::kConcentric:
      return "Concentric";
    case Baseline::kPizza:
      return "Pizza";
    case Baseline::kGreedy:
      return "Greedy";
    case Baseline::kRandomWalk:
      return "RandomWalk";
  }
  return "?";
}

absl::StatusOr<Baseline> ParseBaseline(absl::string_view name) {
  for (const Baseline b : {Baseline::kSpiral, Baseline::kConcentric, Baseline::kPizza,
                           Baseline::kGreedy, Baseline::kRandomWalk}) {
    if (absl::AsciiStrToLower(name) == absl::AsciiStrToLower(BaselineName(b))) return b;
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "unknown baseline '", name, "' (spiral, concentric, pizza, greedy or randomwalk)"));
}

bool IsRandomized(Baseline baseline) {
  return baseline == Baseline::kGreedy || baseline == Baseline::kRandomWalk;
}

absl::StatusOr<std::vector<Polyline>> PlanBaseline(Baseline baseline, const SearchArea& area,
                                                   int n_drones, double budget_m, uint64_t seed,
                                                   const BaselineOptions& options) {
  if (n_drones < 1) return absl::InvalidArgumentError("need at least one drone");
  if (!(budget_m > 0) || !std::isfinite(budget_m)) {
    return absl::InvalidArgumentError("the budget must be a positive number of metres");
  }
  if (area.heatmap.rows < 1 || area.heatmap.cols < 1 || !(area.radius_m > 0) ||
      !std::isfinite(area.center_x_m) || !std::isfinite(area.center_y_m)) {
    return absl::InvalidArgumentError("empty search area");
  }
  if (!(options.point_spacing_m > 0) || !(options.altitude_m > 0) || !(options.fov_deg > 0) ||
      !(options.fov_deg < 180) || !(options.overlap >= 0) || !(options.overlap < 1) ||
      !(options.transition_m >= 0) || !(options.border_gap_m >= 0)) {
    return absl::InvalidArgumentError("baseline options out of range");
  }
  const double per_drone = budget_m / n_drones;
  switch (baseline) {
    case Baseline::kSpiral:
      return ShareOut(SpiralPath(area, options), n_drones, per_drone);
    case Baseline::kConcentric:
      return ShareOut(ConcentricPath(area, options), n_drones, per_drone);
    case Baseline::kPizza: {
      std::vector<Polyline> paths = PizzaPaths(area, n_drones, options);
      for (Polyline& p : paths) p = CutToLength(p, per_drone);
      return paths;
    }
    case Baseline::kGreedy:
      return GreedyPaths(area, area.heatmap, n_drones, budget_m, options, seed);
    case Baseline::kRandomWalk: {
      const Grid2D zeros{.rows = area.heatmap.rows,
                         .cols = area.heatmap.cols,
                         .values = std::vector<double>(area.heatmap.values.size(), 0.0)};
      return GreedyPaths(area, zeros, n_drones, budget_m, options, seed);
    }
  }
  return absl::InvalidArgumentError("unknown baseline");
}

uint64_t DatasetSeed(uint64_t seed, int dataset) {
  return seed * 1000000 + static_cast<uint64_t>(dataset) * 1000;
}

uint64_t BaselineSeed(uint64_t dataset_seed, Baseline baseline, int n_drones) {
  return dataset_seed + 10 * static_cast<uint64_t>(n_drones) +
         (baseline == Baseline::kRandomWalk ? 2 : 1);
}

}  // namespace oaipp::sarenv
