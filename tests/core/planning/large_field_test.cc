// OA-IPP on a field too large for the dense map (core/planning/large_field.h):
// a 120 x 120 m field at 1 m (14,400 cells) with seeded buildings, flown
// plan by plan on the sparse map through the planner's window. Every path
// is checked against the buildings by this file's own distance code at
// 100 Hz, and its shots against the window's reach.
#include "core/planning/large_field.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/planning/planners.h"
#include "gtest/gtest.h"

namespace oaipp {
namespace {

constexpr double kHalfField = 60.0;

struct World {
  std::vector<Box> buildings;
  std::unique_ptr<Environment> env;
};

World MakeWorld(std::uint32_t seed, const Vec3& start) {
  World w;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-kHalfField + 5, kHalfField - 5), size(4, 9),
      height(8, 24);
  std::vector<Obstacle> obstacles;
  while (w.buildings.size() < 14) {
    const Box b{{xy(rng), xy(rng), 0.0}, {size(rng), size(rng), height(rng)}, 0.0};
    if ((b.centre_W.head<2>() - start.head<2>()).cwiseAbs().maxCoeff() < 0.5 * 9 + 4) continue;
    Box placed = b;
    placed.centre_W.z() = 0.5 * b.size_m.z();
    w.buildings.push_back(placed);
    obstacles.push_back({absl::StrCat("b", w.buildings.size()), placed});
  }
  auto env = Environment::Create({{-kHalfField, -kHalfField, 2}, {kHalfField, kHalfField, 26}},
                                 {.voxel_size_m = 0.4});
  EXPECT_TRUE(env.ok()) << env.status();
  EXPECT_TRUE(env->Apply({.add = std::move(obstacles)}).ok());
  w.env = std::make_unique<Environment>(std::move(env).value());
  return w;
}

// Distance from p to the nearest building, by this file's own box geometry.
double DistanceToBuildings(const std::vector<Box>& buildings, const Vec3& p) {
  double best = INFINITY;
  for (const Box& b : buildings) {
    const Vec3 d = ((p - b.centre_W).cwiseAbs() - 0.5 * b.size_m).cwiseMax(0.0);
    best = std::min(best, d.norm());
  }
  return best;
}

// The 120 x 120 m field at 1 m (14,400 cells) and its sparse map at the
// paper's prior.
struct Field {
  FieldGrid grid;
  SparseGpMap map;
};
Field MakeField() {
  auto grid = FieldGrid::FromBounds({-kHalfField, -kHalfField}, {kHalfField, kHalfField}, 1.0);
  EXPECT_TRUE(grid.ok());
  auto map = SparseGpMap::Create(*grid, GpParams::PaperPreset(1.0));
  EXPECT_TRUE(map.ok()) << map.status();
  return {*grid, std::move(map).value()};
}

TEST(LargeFieldTest, OaIppFliesASparseMapThroughItsWindowSafely) {
  const Vec3 start(0, 0, 8);
  const World world = MakeWorld(11, start);
  auto grid = FieldGrid::FromBounds({-kHalfField, -kHalfField}, {kHalfField, kHalfField}, 1.0);
  ASSERT_TRUE(grid.ok());
  // The dense map cannot hold this field; the sparse one can.
  EXPECT_EQ(GpMap::Create(*grid, GpParams::PaperPreset(1.0)).status().code(),
            absl::StatusCode::kResourceExhausted);
  auto map = SparseGpMap::Create(*grid, GpParams::PaperPreset(1.0));
  ASSERT_TRUE(map.ok()) << map.status();
  ASSERT_TRUE(map->FuseNearCertainZeros(grid->CellsUnderObstacles([&](const Vec3& p) {
                   return world.env->IsInsideObstacle(p);
                 }))
                  .ok());
  // Ten people, one cell each, on open ground.
  Eigen::VectorXd truth = Eigen::VectorXd::Zero(grid->num_cells());
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> cell(0, grid->num_cells() - 1);
  for (int placed = 0; placed < 10;) {
    const int c = cell(rng);
    if (world.env->IsInsideObstacle(grid->CellCentre(c) + Vec3(0, 0, 1e-3))) continue;
    truth[c] = 1.0;
    ++placed;
  }
  auto rse = [&]() {
    auto mean = map->Mean();
    EXPECT_TRUE(mean.ok());
    return (*mean - truth).norm();
  };
  const double prior_rse = rse();

  PlannerConfig config{.kind = PlannerKind::kOaIpp};
  config.common.seed = 3;
  config.oaipp.generations = 8;
  auto planner = MakePlanner(config);
  ASSERT_TRUE(planner.ok());
  // What the service plans a large field with (20 cells, 20 m at 1 m).
  const LargeFieldPlanning large = LargeFieldPlanning::ForField(*grid, /*lead=*/true, {});
  const DownwardCamera camera;
  const SensorNoise noise;
  PlanningContext context{world.env.get(), nullptr, camera, noise, 0.0};
  UavState state;
  state.position_W = start;
  double farthest = 0.0;
  int shots = 0;
  for (int plan = 0; plan < 6; ++plan) {
    absl::StatusOr<PlannedPath> path =
        PlanInWindow(**planner, *map, context, state, absl::InfiniteFuture(), large);
    ASSERT_TRUE(path.ok()) << path.status();
    const Vec2 from = state.position_W.head<2>();
    // The window leads the UAV by at most lead_fraction x half_width_m.
    const double reach = (1.0 + large.lead_fraction) * large.half_width_m + grid->resolution_m();
    for (const Vec3& w : path->control_waypoints_W) {
      EXPECT_LE((w.head<2>() - from).cwiseAbs().maxCoeff(), reach) << plan;
    }
    const double duration = path->trajectory.Duration();
    for (double t = 0.0; t <= duration; t += 0.01) {
      const Vec3 p = path->trajectory.Position(t);
      ASSERT_GE(DistanceToBuildings(world.buildings, p), 0.5 * config.common.limits.uav_radius_m)
          << "plan " << plan << " at t = " << t;
      ASSERT_LE(p.head<2>().cwiseAbs().maxCoeff(), kHalfField + 1e-6);
    }
    for (const MeasurementPose& pose : path->measurement_poses) {
      const std::vector<int> cells =
          camera.VisibleFootprintCells(*grid, pose.position_W, world.env.get());
      std::vector<double> labels;
      for (int c : cells) labels.push_back(truth[c]);
      auto obs = LabelsToObservations(*grid, noise, pose.position_W.z(), cells, labels);
      ASSERT_TRUE(obs.ok());
      ASSERT_TRUE(map->Update(*obs).ok());
      ++shots;
    }
    state = StateAlong(path->trajectory, duration, state.mission_time_s);
    context.next_shot_mission_s = path->next_shot_mission_s;
    farthest = std::max(farthest, (state.position_W.head<2>() - start.head<2>()).norm());
  }
  EXPECT_GE(shots, 6);
  // The map learnt from the shots.
  EXPECT_LT(rse(), prior_rse);
  RecordProperty("farthest_m", std::to_string(farthest));
  RecordProperty("rse", std::to_string(rse()));
  std::printf("%d shots, farthest %.1f m from the start, RSE %.3f (prior %.3f)\n", shots, farthest,
              rse(), prior_rse);
}

// The window's centre (WindowCentre): on the UAV while its own
// neighbourhood is worth most, leading towards the one unobserved square
// of a field whose other cells are all well observed. The expected centres
// come from the square's geometry: a 120 x 120 m field at 1 m cut into
// 20 m squares, the unobserved one the north-east corner's (cells 100-119
// each way, centre (50, 50)).
TEST(LargeFieldTest, TheWindowLeadsTowardsTheOnlyUnobservedSquare) {
  auto grid = FieldGrid::FromBounds({-kHalfField, -kHalfField}, {kHalfField, kHalfField}, 1.0);
  ASSERT_TRUE(grid.ok());
  const LargeFieldPlanning large = LargeFieldPlanning::ForField(*grid, /*lead=*/true, {});
  ASSERT_EQ(large.half_width_m, 20.0);
  const double p0 = 1.5;
  const Vec2 uav(0.0, 0.0);
  // Nothing observed: the UAV's own square is worth most.
  Eigen::VectorXd added = Eigen::VectorXd::Zero(grid->num_cells());
  EXPECT_EQ(WindowCentre(*grid, added, p0, uav, large), uav);
  // Everything but the corner observed well (variance p0 / 1001 each).
  added.setConstant(1000.0 / p0);
  for (int r = 100; r < 120; ++r) {
    for (int c = 100; c < 120; ++c) added[grid->Index(r, c)] = 0.0;
  }
  const Vec2 centre = WindowCentre(*grid, added, p0, uav, large);
  const Vec2 expected = uav + Vec2(50.0, 50.0).normalized() * (large.lead_fraction * 20.0);
  EXPECT_NEAR(centre.x(), expected.x(), 1e-9);
  EXPECT_NEAR(centre.y(), expected.y(), 1e-9);
  // Within 20 m of the square's centre the UAV plans around itself.
  EXPECT_EQ(WindowCentre(*grid, added, p0, Vec2(40.0, 45.0), large), Vec2(40.0, 45.0));
  // lead_fraction 0: always on the UAV.
  LargeFieldPlanning centred = large;
  centred.lead_fraction = 0.0;
  EXPECT_EQ(WindowCentre(*grid, added, p0, uav, centred), uav);
  // A square twice as far, with the same uncertainty, is worth less than
  // one near: the south-west corner too left unobserved, the UAV nearer it.
  for (int r = 0; r < 20; ++r) {
    for (int c = 0; c < 20; ++c) added[grid->Index(r, c)] = 0.0;
  }
  const Vec2 near_sw(-20.0, -20.0);
  const Vec2 towards_sw = WindowCentre(*grid, added, p0, near_sw, large);
  EXPECT_LT((towards_sw - Vec2(-50.0, -50.0)).norm(), (near_sw - Vec2(-50.0, -50.0)).norm());

  // The window the service plans in (PlanningWindow): the cells overlapping
  // 20 m each way of the UAV before anything is added (the UAV on a cell
  // corner: 40 x 40 cells from (-20, -20)), around the lead's centre after.
  const absl::StatusOr<FieldWindow> fresh = PlanningWindow(*grid, nullptr, p0, uav, large);
  ASSERT_TRUE(fresh.ok()) << fresh.status();
  EXPECT_EQ(fresh->grid.nx(), 40);
  EXPECT_EQ(fresh->grid.ny(), 40);
  EXPECT_NEAR(fresh->grid.min_W().x(), -20.0, 1e-9);
  EXPECT_NEAR(fresh->grid.min_W().y(), -20.0, 1e-9);
  const absl::StatusOr<FieldWindow> leading = PlanningWindow(*grid, &added, p0, near_sw, large);
  ASSERT_TRUE(leading.ok()) << leading.status();
  const absl::StatusOr<FieldWindow> around = WindowAround(*grid, towards_sw, large.half_width_m);
  ASSERT_TRUE(around.ok());
  EXPECT_EQ(leading->first_row, around->first_row);
  EXPECT_EQ(leading->first_col, around->first_col);
  LargeFieldPlanning bad = large;
  bad.lead_fraction = 1.0;
  EXPECT_EQ(PlanningWindow(*grid, &added, p0, uav, bad).status().code(),
            absl::StatusCode::kInvalidArgument);
  const Eigen::VectorXd short_added = Eigen::VectorXd::Zero(10);
  EXPECT_EQ(PlanningWindow(*grid, &short_added, p0, uav, large).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// With a search area only its cells count: before anything is observed,
// a UAV in the middle of a field whose area is the north-east corner's
// square (cells 100-119 each way, centre (50, 50)) is led towards it, by
// WindowCentre and by the window the service plans in.
// The field's square [40, 60]^2 m as a search area (cells 100-119 each way).
std::vector<std::uint8_t> CornerArea(const FieldGrid& grid) {
  std::vector<std::uint8_t> area(static_cast<std::size_t>(grid.num_cells()), 0);
  for (int r = 100; r < 120; ++r) {
    for (int c = 100; c < 120; ++c) area[static_cast<std::size_t>(grid.Index(r, c))] = 1;
  }
  return area;
}

TEST(LargeFieldTest, TheWindowLeadsIntoTheSearchArea) {
  auto grid = FieldGrid::FromBounds({-kHalfField, -kHalfField}, {kHalfField, kHalfField}, 1.0);
  ASSERT_TRUE(grid.ok());
  const LargeFieldPlanning large = LargeFieldPlanning::ForField(*grid, /*lead=*/true, {});
  const std::vector<std::uint8_t> area = CornerArea(*grid);
  const Vec2 uav(0.0, 0.0);
  const Vec2 expected = uav + Vec2(50.0, 50.0).normalized() * (large.lead_fraction * 20.0);
  const Eigen::VectorXd none = Eigen::VectorXd::Zero(grid->num_cells());
  EXPECT_EQ(WindowCentre(*grid, none, 1.5, uav, large), uav);
  const Vec2 centre = WindowCentre(*grid, none, 1.5, uav, large, area);
  EXPECT_NEAR(centre.x(), expected.x(), 1e-9);
  EXPECT_NEAR(centre.y(), expected.y(), 1e-9);
  const absl::StatusOr<FieldWindow> window = PlanningWindow(*grid, nullptr, 1.5, uav, large, area);
  ASSERT_TRUE(window.ok()) << window.status();
  const absl::StatusOr<FieldWindow> around = WindowAround(*grid, expected, large.half_width_m);
  ASSERT_TRUE(around.ok());
  EXPECT_EQ(window->first_row, around->first_row);
  EXPECT_EQ(window->first_col, around->first_col);
  EXPECT_EQ(
      PlanningWindow(*grid, nullptr, 1.5, uav, large, std::span(area).first(10)).status().code(),
      absl::StatusCode::kInvalidArgument);
}

// The area [40, 60]^2 m lies beyond the window of a plan from the centre
// (led to (10.6, 10.6), cells -10 ... 31 m each way): its stand-in is the
// window's cells within 5 m (a quarter of the half width) of the window's
// corner cell centre (30.5, 30.5), nearest the area cell (40.5, 40.5):
// the lattice points of a quarter disc of radius 5, 26 cells. A window
// holding one area cell, no area, or an area of no cell: none.
TEST(TransitAreaTest, AFarAreaIsStoodInForByTheWindowsCellsNearestIt) {
  auto grid = FieldGrid::FromBounds({-kHalfField, -kHalfField}, {kHalfField, kHalfField}, 1.0);
  ASSERT_TRUE(grid.ok());
  const LargeFieldPlanning large = LargeFieldPlanning::ForField(*grid, /*lead=*/true, {});
  const std::vector<std::uint8_t> area = CornerArea(*grid);
  const Vec2 uav(0.0, 0.0);
  const absl::StatusOr<FieldWindow> window = PlanningWindow(*grid, nullptr, 1.5, uav, large, area);
  ASSERT_TRUE(window.ok()) << window.status();
  const std::vector<std::uint8_t> transit = TransitArea(*grid, *window, area, uav, 5.0);
  ASSERT_EQ(transit.size(), area.size());
  int count = 0;
  for (int cell = 0; cell < grid->num_cells(); ++cell) {
    if (transit[static_cast<std::size_t>(cell)] == 0) continue;
    ++count;
    const Vec2 c = grid->CellCentreXY(cell);
    EXPECT_LE((c - Vec2(30.5, 30.5)).norm(), 5.0) << c.transpose();
    EXPECT_LE(c.maxCoeff(), 30.5) << c.transpose();
  }
  EXPECT_EQ(count, 26);
  // The window reaches one area cell: the area itself serves.
  std::vector<std::uint8_t> near = area;
  near[static_cast<std::size_t>(window->field_cells.front())] = 1;
  EXPECT_TRUE(TransitArea(*grid, *window, near, uav, 5.0).empty());
  EXPECT_TRUE(TransitArea(*grid, *window, {}, uav, 5.0).empty());
  const std::vector<std::uint8_t> nothing(area.size(), 0);
  EXPECT_TRUE(TransitArea(*grid, *window, nothing, uav, 5.0).empty());
}

// OA-IPP on a field whose part around the UAV is already well observed
// (every cell but those with x >= 22 m and y >= 22 m, seen empty): centred on
// the UAV, its window (+-20 m) holds nothing left to learn and the plan
// stays put; leading, the window reaches into the unobserved corner and the
// plan ends more than 10 m nearer the corner's square than it started.
// People are nowhere.
TEST(LargeFieldTest, OaIppHeadsForTheUnobservedPartOfTheField) {
  const Vec3 start(0, 0, 8);
  const World world = MakeWorld(11, start);
  Field field = MakeField();
  const FieldGrid* grid = &field.grid;
  SparseGpMap* map = &field.map;
  std::vector<CellObservation> seen;
  for (int cell = 0; cell < grid->num_cells(); ++cell) {
    const Vec2 c = grid->CellCentreXY(cell);
    if (c.x() >= 22.0 && c.y() >= 22.0) continue;
    seen.push_back({.cell = cell, .value = 0.0, .variance = 1e-3});
  }
  ASSERT_TRUE(map->Update(seen).ok());
  PlannerConfig config{.kind = PlannerKind::kOaIpp};
  config.common.seed = 3;
  config.oaipp.generations = 8;
  auto planner = MakePlanner(config);
  ASSERT_TRUE(planner.ok());
  PlanningContext context{world.env.get(), nullptr, DownwardCamera(), SensorNoise(), 0.0};
  UavState state;
  state.position_W = start;
  const LargeFieldPlanning large = LargeFieldPlanning::ForField(*grid, /*lead=*/true, {});
  // Where the window goes, by this test's own reckoning: the corner square
  // (centre (50, 50)) is the worthiest, so 15 m towards it.
  const Vec2 expected = Vec2(50.0, 50.0).normalized() * (large.lead_fraction * 20.0);
  const Vec2 centre = WindowCentre(*grid, map->AddedPrecision(),
                                   map->prior().fit.fitted_p0_variance, start.head<2>(), large);
  EXPECT_NEAR((centre - expected).norm(), 0.0, 1e-9);
  const Vec2 corner(50.0, 50.0);
  for (const double lead : {0.0, large.lead_fraction}) {
    SCOPED_TRACE(absl::StrCat("lead_fraction ", lead));
    LargeFieldPlanning options = large;
    options.lead_fraction = lead;
    absl::StatusOr<PlannedPath> path =
        PlanInWindow(**planner, *map, context, state, absl::InfiniteFuture(), options);
    ASSERT_TRUE(path.ok()) << path.status();
    const Vec2 end = path->trajectory.Position(path->trajectory.Duration()).head<2>();
    const double gained = (start.head<2>() - corner).norm() - (end - corner).norm();
    if (lead == 0.0) {
      EXPECT_LT(gained, 10.0) << "end (" << end.x() << ", " << end.y() << ")";
      continue;
    }
    EXPECT_GT(gained, 10.0) << "end (" << end.x() << ", " << end.y() << ")";
    for (const Vec3& w : path->control_waypoints_W) {
      EXPECT_LE((w.head<2>() - centre).cwiseAbs().maxCoeff(), 20.0 + grid->resolution_m());
    }
  }
}

// The lawnmower's pattern and the random planner's destinations cover the
// whole field (PlanningContext::field) although they plan on a window: their
// waypoints reach beyond it; without the field they stay inside it.
TEST(LargeFieldTest, TheBaselinesCoverTheWholeFieldFromAWindow) {
  const Vec3 start(0, 0, 8);
  const World world = MakeWorld(11, start);
  Field field = MakeField();
  const FieldGrid* grid = &field.grid;
  SparseGpMap* map = &field.map;
  // The service's setting for the baselines: no lead.
  const LargeFieldPlanning large = LargeFieldPlanning::ForField(*grid, /*lead=*/false, {});
  const double window_reach = large.half_width_m + grid->resolution_m();
  for (const PlannerKind kind : {PlannerKind::kLawnmower, PlannerKind::kRandom}) {
    for (const bool whole_field : {false, true}) {
      SCOPED_TRACE(absl::StrCat(kind == PlannerKind::kRandom ? "random" : "lawnmower",
                                whole_field ? " with the field" : " on the window alone"));
      PlannerConfig config{.kind = kind};
      config.common.seed = 3;
      auto planner = MakePlanner(config);
      ASSERT_TRUE(planner.ok());
      PlanningContext context{world.env.get(), nullptr, DownwardCamera(), SensorNoise(), 0.0};
      if (whole_field) context.field = &*grid;
      double farthest = 0.0;
      for (double time_s : {0.0, 10.0}) {
        UavState state;
        state.position_W = start;
        state.mission_time_s = time_s;
        context.next_shot_mission_s = time_s;
        absl::StatusOr<PlannedPath> path =
            PlanInWindow(**planner, *map, context, state, absl::InfiniteFuture(), large);
        ASSERT_TRUE(path.ok()) << path.status();
        for (const Vec3& w : path->control_waypoints_W) {
          farthest = std::max(farthest, (w.head<2>() - start.head<2>()).cwiseAbs().maxCoeff());
        }
      }
      if (whole_field) {
        EXPECT_GT(farthest, window_reach + 10.0);
      } else {
        EXPECT_LE(farthest, window_reach);
      }
    }
  }
}

}  // namespace
}  // namespace oaipp
