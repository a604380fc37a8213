#include "core/planning/baseline_planners.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <queue>
#include <random>
#include <span>
#include <utility>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"
#include "core/planning/oaipp_planner.h"
#include "core/trajectory/min_snap.h"

namespace oaipp {
namespace {

// Corners of a shape's footprint grown by `grow` metres, at height z.
std::vector<Vec3> InflatedCorners(const Shape& shape, double grow, double z) {
  std::vector<Vec3> corners;
  if (const Box* box = std::get_if<Box>(&shape)) {
    const double c = std::cos(box->yaw_rad), s = std::sin(box->yaw_rad);
    // Corners of the box grown by `grow` and pushed out a little more along
    // the diagonal so that the route's segments clear the rounded corner.
    const double hx = 0.5 * box->size_m.x() + grow, hy = 0.5 * box->size_m.y() + grow;
    for (int sx : {-1, 1}) {
      for (int sy : {-1, 1}) {
        const double lx = sx * hx, ly = sy * hy;
        corners.emplace_back(box->centre_W.x() + c * lx - s * ly,
                             box->centre_W.y() + s * lx + c * ly, z);
      }
    }
    return corners;
  }
  if (const Prism* prism = std::get_if<Prism>(&shape)) {
    // The corners of its footprint's bounding box grown as a box's: the
    // box holds the footprint, so legs along its grown edges pass it.
    const Aabb bounds = prism->BoundingBox();
    const double g = grow;
    for (const Vec2& c : {Vec2(bounds.min_W.x() - g, bounds.min_W.y() - g),
                          Vec2(bounds.max_W.x() + g, bounds.min_W.y() - g),
                          Vec2(bounds.min_W.x() - g, bounds.max_W.y() + g),
                          Vec2(bounds.max_W.x() + g, bounds.max_W.y() + g)}) {
      corners.emplace_back(c.x(), c.y(), z);
    }
    return corners;
  }
  const Cylinder& cyl = std::get<Cylinder>(shape);
  // An octagon around the grown circle: its edges stay outside the circle.
  const double r = (cyl.radius_m + grow) / std::cos(kPi / 8.0);
  for (int k = 0; k < 8; ++k) {
    const double a = kPi / 8.0 + k * kPi / 4.0;
    corners.emplace_back(cyl.centre_W.x() + r * std::cos(a), cyl.centre_W.y() + r * std::sin(a), z);
  }
  return corners;
}

}  // namespace

absl::StatusOr<std::vector<Vec3>> DetourAround(const Environment& environment, const Vec3& from,
                                               const Vec3& to, double clearance_m,
                                               const Aabb& box) {
  if (environment.IsSegmentClear(from, to, clearance_m)) return std::vector<Vec3>{};
  // Visibility graph over the grown corners of every obstacle, at the
  // higher of the two heights; Dijkstra from `from` to `to`.
  const double z = std::max(from.z(), to.z());
  std::vector<Vec3> nodes{from, to};
  // Every segment of the graph lies between these heights: a shape wholly
  // above or below them (by the clearance) is in no segment's way.
  const double z_low = std::min(from.z(), to.z()) - clearance_m;
  const double z_high = z + clearance_m;
  const auto add_corners = [&](const Shape& shape) {
    const Aabb bounds = BoundingBox(shape);
    if (bounds.max_W.z() < z_low || bounds.min_W.z() > z_high) return;
    for (const Vec3& c : InflatedCorners(shape, clearance_m * 1.05 + 0.05, z)) {
      if (box.Contains(c) && environment.SignedDistance(c) > clearance_m) nodes.push_back(c);
    }
  };
  for (const auto& [id, obstacle] : environment.obstacles()) add_corners(obstacle.shape);
  for (const Obstacle& zone : environment.airspace().zones()) add_corners(zone.shape);
  // A polygon fence's corners moved inside by the same margin from both of
  // their edges (where the offset edges meet): the way round a corner that
  // juts in.
  if (const std::optional<Fence>& fence = environment.airspace().fence(); fence.has_value()) {
    const std::vector<Vec2>& ring = fence->polygon_W;  // counter-clockwise
    const double g = clearance_m * 1.05 + 0.05;
    for (std::size_t i = 0; i < ring.size(); ++i) {
      const Vec2& prev = ring[(i + ring.size() - 1) % ring.size()];
      const Vec2& next = ring[(i + 1) % ring.size()];
      const Vec2 e1 = (ring[i] - prev).normalized(), e2 = (next - ring[i]).normalized();
      const Vec2 n1(-e1.y(), e1.x()), n2(-e2.y(), e2.x());  // inward normals
      if (!(1.0 + n1.dot(n2) > 1e-6)) continue;             // a fold: no corner
      const Vec2 c = ring[i] + g * (n1 + n2) / (1.0 + n1.dot(n2));
      const Vec3 node(c.x(), c.y(), z);
      if (box.Contains(node) && environment.SignedDistance(node) > clearance_m) {
        nodes.push_back(node);
      }
    }
  }
  // A*: the straight distance to `to` never overestimates what is left and
  // obeys the triangle inequality, so the first time `to` is taken from the
  // queue its route is the shortest, and nodes far off the way are never
  // expanded (each expansion tests segments against every obstacle).
  const int n = static_cast<int>(nodes.size());
  std::vector<double> dist(n, std::numeric_limits<double>::infinity());
  std::vector<double> to_go(n);
  for (int v = 0; v < n; ++v) to_go[v] = (nodes[v] - nodes[1]).norm();
  std::vector<int> parent(n, -1);
  std::vector<bool> done(n, false);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  dist[0] = 0.0;
  queue.push({to_go[0], 0});
  while (!queue.empty()) {
    const int u = queue.top().second;
    queue.pop();
    if (done[u]) continue;
    done[u] = true;
    if (u == 1) break;
    for (int v = 1; v < n; ++v) {
      if (done[v]) continue;
      const double w = (nodes[v] - nodes[u]).norm();
      if (dist[u] + w >= dist[v]) continue;
      if (!environment.IsSegmentClear(nodes[u], nodes[v], clearance_m)) continue;
      dist[v] = dist[u] + w;
      parent[v] = u;
      queue.push({dist[v] + to_go[v], v});
    }
  }
  if (parent[1] < 0) {
    return absl::NotFoundError("no route around the obstacles between the two points");
  }
  std::vector<Vec3> route;
  for (int v = parent[1]; v != 0; v = parent[v]) route.push_back(nodes[v]);
  std::reverse(route.begin(), route.end());
  return route;
}

absl::Status LawnmowerConfig::Validate() const {
  OAIPP_RETURN_IF_ERROR(CheckPositive("lawnmower.altitude_m", altitude_m));
  if (points_per_plan < 1)
    return absl::InvalidArgumentError("lawnmower.points_per_plan: must be >= 1");
  if (start_corner < -1 || start_corner > 3) {
    return absl::InvalidArgumentError(
        absl::StrCat("lawnmower.start_corner: must be -1 (seeded) or 0-3, got ", start_corner));
  }
  if (!(detour_margin_m >= 0.0) || !std::isfinite(detour_margin_m)) {
    return absl::InvalidArgumentError("lawnmower.detour_margin_m: must be >= 0 and finite");
  }
  return absl::OkStatus();
}

namespace {

// The stretches [x0, x1] of the lane band [y_lo, y_hi] over which some cell
// of `area` lies, as runs of the grid's columns, in increasing x.
std::vector<std::pair<double, double>> AreaStretches(const FieldGrid& grid,
                                                     std::span<const std::uint8_t> area,
                                                     double y_lo, double y_hi) {
  const double res = grid.resolution_m();
  const int row_lo =
      std::clamp(static_cast<int>(std::floor((y_lo - grid.min_W().y()) / res)), 0, grid.ny() - 1);
  const int row_hi = std::clamp(static_cast<int>(std::ceil((y_hi - grid.min_W().y()) / res)) - 1,
                                row_lo, grid.ny() - 1);
  std::vector<std::pair<double, double>> stretches;
  int run_start = -1;
  for (int col = 0; col <= grid.nx(); ++col) {
    bool inside = false;
    for (int row = row_lo; col < grid.nx() && row <= row_hi && !inside; ++row) {
      inside = area[static_cast<std::size_t>(grid.Index(row, col))] != 0;
    }
    if (inside && run_start < 0) run_start = col;
    if (!inside && run_start >= 0) {
      stretches.emplace_back(grid.min_W().x() + run_start * res, grid.min_W().x() + col * res);
      run_start = -1;
    }
  }
  return stretches;
}

}  // namespace

std::vector<Vec3> LawnmowerPlanner::Pattern(const FieldGrid& grid, const Aabb& waypoint_box,
                                            const DownwardCamera& camera, double altitude_m,
                                            int corner, std::span<const std::uint8_t> area) {
  const Vec2 footprint = camera.FootprintSize(altitude_m);
  const Vec2 lo = grid.min_W(), hi = grid.max_W();
  // Lanes along x, spaced by the footprint's y extent (the longer side for
  // the default camera: fewer lanes, shorter pattern).
  const int lanes =
      std::max(1, static_cast<int>(std::ceil((hi.y() - lo.y()) / footprint.y() - 1e-9)));
  const double spacing = (hi.y() - lo.y()) / lanes;
  const double x_start = std::max(lo.x() + 0.5 * footprint.x(), waypoint_box.min_W.x());
  const double x_end = std::min(hi.x() - 0.5 * footprint.x(), waypoint_box.max_W.x());
  const double z = std::clamp(altitude_m, waypoint_box.min_W.z(), waypoint_box.max_W.z());
  std::vector<Vec3> points;
  const bool from_top = (corner & 1) != 0;
  const bool from_high_x = (corner & 2) != 0;
  int lanes_flown = 0;  // with an area: lanes that hold some of it
  for (int k = 0; k < lanes; ++k) {
    const int lane = from_top ? lanes - 1 - k : k;
    const double y =
        std::clamp(lo.y() + (lane + 0.5) * spacing, waypoint_box.min_W.y(), waypoint_box.max_W.y());
    const bool forward = (k % 2 == 0) != from_high_x;
    if (area.empty()) {
      points.emplace_back(forward ? x_start : x_end, y, z);
      points.emplace_back(forward ? x_end : x_start, y, z);
      continue;
    }
    // Alternate lanes by the lanes flown, so that a lane left out does not
    // turn the next one around.
    const bool ahead = (lanes_flown % 2 == 0) != from_high_x;
    std::vector<Vec3> lane_points;
    for (const auto& [x0, x1] : AreaStretches(grid, area, y - 0.5 * spacing, y + 0.5 * spacing)) {
      double a = std::max(x0 + 0.5 * footprint.x(), waypoint_box.min_W.x());
      double b = std::min(x1 - 0.5 * footprint.x(), waypoint_box.max_W.x());
      if (a > b)
        a = b = std::clamp(0.5 * (x0 + x1), waypoint_box.min_W.x(), waypoint_box.max_W.x());
      lane_points.emplace_back(a, y, z);
      lane_points.emplace_back(b, y, z);
    }
    if (lane_points.empty()) continue;
    ++lanes_flown;
    if (!ahead) std::reverse(lane_points.begin(), lane_points.end());
    points.insert(points.end(), lane_points.begin(), lane_points.end());
  }
  return points;
}

absl::StatusOr<PlannedPath> LawnmowerPlanner::Plan(const PlanningContext& mission,
                                                   const UavState& state, absl::Time deadline) {
  const absl::Time started = absl::Now();
  OAIPP_RETURN_IF_ERROR(config_.Validate());
  OAIPP_ASSIGN_OR_RETURN(PathScorer scorer, PathScorer::Create(mission, state, common_));
  const Environment& env = scorer.environment();
  if (pattern_.empty()) {
    const int corner = config_.start_corner >= 0
                           ? config_.start_corner
                           : static_cast<int>(MixSeed(common_.seed, 0.0) & 3U);
    // Inside a fence, the lanes run over the cells a clearance and a cell
    // inside it (of the search area, if any): lanes across the whole field
    // would end where the UAV may not go.
    std::vector<std::uint8_t> inside;
    if (env.airspace().fence().has_value()) {
      const FieldGrid& grid = scorer.field();
      const double margin = common_.limits.ObstacleClearance() + grid.resolution_m();
      inside.assign(static_cast<std::size_t>(grid.num_cells()), 0);
      for (int c = 0; c < grid.num_cells(); ++c) {
        const bool in_area = mission.search_area.empty() || mission.search_area[c] != 0;
        inside[c] = in_area && env.airspace().FenceSignedDistance(grid.CellCentreXY(c)) >= margin;
      }
    }
    pattern_ = Pattern(scorer.field(), scorer.waypoint_box(), mission.camera, config_.altitude_m,
                       corner, inside.empty() ? mission.search_area : inside);
    if (pattern_.empty()) {
      return absl::FailedPreconditionError(
          "lawnmower: the search area holds no cell of the field inside the fence");
    }
  }
  // Back and forth: after the last point the pattern is flown in reverse.
  const int period = 2 * static_cast<int>(pattern_.size()) - 2;
  auto point = [&](int index) {
    if (period <= 0) return pattern_.front();
    const int i = index % period;
    return i < static_cast<int>(pattern_.size()) ? pattern_[i] : pattern_[period - i];
  };
  const double clearance = common_.limits.ObstacleClearance();

  // Each pattern point is reached through a detour that keeps `margin` of
  // extra clearance, or less (down to detour_margin_m / 2, then none) where
  // a passage is too narrow for it; points that cannot be reached at all
  // (under a tall building, walled off) are skipped. The smooth trajectory
  // cuts the detour's corners, so when the exact check fails the route is
  // rebuilt with twice the margin, then half, then none (a different
  // detour), then all of these again with its legs split into pieces of at
  // most 3 m, which the trajectory follows more closely; last, points that
  // need a narrower detour are skipped instead.
  struct Attempt {
    double margin;
    bool split;          // legs in pieces of at most 3 m
    bool narrow = true;  // a point unreachable with `margin` may use less
  };
  auto build_route = [&](const Attempt& attempt, int* index) {
    const double margin = attempt.margin;
    const bool split = attempt.split;
    std::vector<Vec3> route;
    Vec3 previous = state.position_W;
    int reached = 0;
    const int first = *index;
    while (reached < config_.points_per_plan && *index - first < std::max(period, 1)) {
      const Vec3 target = point((*index)++);
      const double m = config_.detour_margin_m;
      double tried = -1.0;
      for (double extra : {margin, m, 0.5 * m, 0.0}) {
        if (extra > margin || extra == tried || (!attempt.narrow && extra < margin)) continue;
        tried = extra;
        if (env.SignedDistance(target) <= clearance + extra) continue;
        absl::StatusOr<std::vector<Vec3>> detour =
            DetourAround(env, previous, target, clearance + extra, scorer.waypoint_box());
        if (!detour.ok()) continue;
        detour->push_back(target);
        for (const Vec3& corner : *detour) {
          const int pieces =
              split ? std::max(1, static_cast<int>(std::ceil((corner - previous).norm() / 3.0)))
                    : 1;
          for (int k = 1; k <= pieces; ++k) {
            route.push_back(previous + (corner - previous) * (static_cast<double>(k) / pieces));
          }
          previous = corner;
        }
        ++reached;
        break;
      }
    }
    return route;
  };
  absl::Status last_error = absl::OkStatus();
  // A scored route is flown if it passes the exact check.
  auto fly_if_safe = [&](ScoredPath scored, const std::vector<Vec3>& route, int index,
                         const char* how) -> std::optional<PlannedPath> {
    if (!scored.ok()) {
      last_error = absl::FailedPreconditionError("no feasible trajectory along the pattern");
      return std::nullopt;
    }
    if (absl::Status exact = scorer.CheckExact(*scored.trajectory); !exact.ok()) {
      last_error = exact;
      return std::nullopt;
    }
    next_index_ = index;
    PlannerStats stats{.evaluations = 1,
                       .wall_time_s = absl::ToDoubleSeconds(absl::Now() - started),
                       .stop_reason = how};
    return scorer.Finish(std::move(scored), route, std::move(stats));
  };
  const double m = config_.detour_margin_m;
  const Attempt attempts[] = {
      {m, false},    {2 * m, false},  {0.5 * m, false}, {0.0, false},      {m, true},
      {2 * m, true}, {0.5 * m, true}, {0.0, true},      {m, false, false}, {0.5 * m, false, false}};
  for (const Attempt& attempt : attempts) {
    int index = next_index_;
    const std::vector<Vec3> route = build_route(attempt, &index);
    if (route.empty()) {
      last_error = absl::FailedPreconditionError("no pattern point reachable from the UAV");
      continue;
    }
    if (auto path = fly_if_safe(scorer.Score(route), route, index, "pattern")) {
      return *std::move(path);
    }
  }
  // Last resort from rest: the route flown stop and go, one straight leg
  // per detour corner, so it keeps the detour's own clearance exactly.
  const bool at_rest = AtRest(state.velocity_W_m_s, state.accel_W_m_s2);
  for (const double margin : {m, 0.5 * m}) {
    if (!at_rest || absl::Now() >= deadline) break;
    int index = next_index_;
    const std::vector<Vec3> route = build_route({margin, false}, &index);
    if (route.empty()) continue;
    std::vector<Vec3> points{state.position_W};
    points.insert(points.end(), route.begin(), route.end());
    absl::StatusOr<PolynomialTrajectory> legs = PlanStopAndGo(points, common_.limits.dynamics);
    if (!legs.ok()) {
      last_error = legs.status();
      continue;
    }
    if (auto path = fly_if_safe(scorer.ScoreTrajectory(*std::move(legs)), route, index,
                                "pattern_stop_and_go")) {
      return *std::move(path);
    }
  }
  if (absl::Now() >= deadline) return absl::DeadlineExceededError("lawnmower: deadline passed");
  return absl::FailedPreconditionError(absl::StrCat("lawnmower: ", last_error.message()));
}

std::string LawnmowerPlanner::SaveState() const { return absl::StrCat(next_index_); }

absl::Status LawnmowerPlanner::RestoreState(absl::string_view state) {
  int index = 0;
  if (!absl::SimpleAtoi(state, &index) || index < 0) {
    return absl::InvalidArgumentError("planner state: not a lawnmower pattern index");
  }
  next_index_ = index;
  return absl::OkStatus();
}

absl::Status RandomConfig::Validate() const {
  if (max_attempts < 1) return absl::InvalidArgumentError("random.max_attempts: must be >= 1");
  return absl::OkStatus();
}

absl::StatusOr<PlannedPath> RandomPlanner::Plan(const PlanningContext& mission,
                                                const UavState& state, absl::Time deadline) {
  const absl::Time started = absl::Now();
  OAIPP_RETURN_IF_ERROR(config_.Validate());
  OAIPP_ASSIGN_OR_RETURN(PathScorer scorer, PathScorer::Create(mission, state, common_));
  std::mt19937_64 rng(MixSeed(common_.seed, state.mission_time_s));
  const Aabb& box = scorer.waypoint_box();
  const Vec2 lo = scorer.field().min_W().cwiseMax(box.min_W.head<2>());
  const Vec2 hi = scorer.field().max_W().cwiseMin(box.max_W.head<2>());
  std::uniform_real_distribution<double> ux(lo.x(), hi.x()), uy(lo.y(), hi.y()),
      uz(box.min_W.z(), box.max_W.z());
  // With a search area: a cell drawn among the area's cells, then a point
  // in it (uniform over the area as the grid draws it), kept to [lo, hi].
  std::vector<int> inside;
  const FieldGrid& field = scorer.field();
  for (std::size_t c = 0; c < mission.search_area.size(); ++c) {
    if (mission.search_area[c] != 0) inside.push_back(static_cast<int>(c));
  }
  if (!mission.search_area.empty() && inside.empty()) {
    return absl::FailedPreconditionError("random: the search area holds no cell of the field");
  }
  std::uniform_int_distribution<std::size_t> pick(0, inside.empty() ? 0 : inside.size() - 1);
  std::uniform_real_distribution<double> offset(-0.5, 0.5);
  auto draw = [&]() -> Vec3 {
    // Without an area, the draw as it always was (the pinned plans).
    if (inside.empty()) return Vec3(ux(rng), uy(rng), uz(rng));
    const Vec2 centre = field.CellCentreXY(inside[pick(rng)]);
    const double dx = offset(rng);
    const double dy = offset(rng);
    const Vec2 xy = (centre + field.resolution_m() * Vec2(dx, dy)).cwiseMax(lo).cwiseMin(hi);
    const double z = uz(rng);
    return Vec3(xy.x(), xy.y(), z);
  };
  const double clearance = common_.limits.ObstacleClearance();
  PlannerStats stats;
  for (int attempt = 0; attempt < config_.max_attempts; ++attempt) {
    if (absl::Now() >= deadline) return absl::DeadlineExceededError("random: deadline passed");
    const Vec3 p = draw();
    if (scorer.environment().SignedDistance(p) <= clearance) continue;
    ScoredPath scored = scorer.Score({p});
    ++stats.evaluations;
    if (!scored.ok() || !scorer.CheckExact(*scored.trajectory).ok()) continue;
    stats.stop_reason = "sampled";
    stats.wall_time_s = absl::ToDoubleSeconds(absl::Now() - started);
    return scorer.Finish(std::move(scored), {p}, std::move(stats));
  }
  return absl::FailedPreconditionError(absl::StrCat("random: none of ", config_.max_attempts,
                                                    " sampled destinations was reachable safely"));
}

}  // namespace oaipp
