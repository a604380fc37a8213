// OA-IPP on a field too large for the dense map (core/planning/large_field.h):
// a 120 x 120 m field at 1 m (14,400 cells) with seeded buildings, flown
// plan by plan on the sparse map through the planner's window. Every path
// is checked against the buildings by this file's own distance code at
// 100 Hz, and its shots against the window's reach.
#include "core/planning/large_field.h"

#include <algorithm>
#include <cmath>
#include <random>
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
  const LargeFieldPlanning large{};
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
    const double reach = large.half_width_m + grid->resolution_m();
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

// The lawnmower's pattern and the random planner's destinations cover the
// whole field (PlanningContext::field) although they plan on a window: their
// waypoints reach beyond it; without the field they stay inside it.
TEST(LargeFieldTest, TheBaselinesCoverTheWholeFieldFromAWindow) {
  const Vec3 start(0, 0, 8);
  const World world = MakeWorld(11, start);
  auto grid = FieldGrid::FromBounds({-kHalfField, -kHalfField}, {kHalfField, kHalfField}, 1.0);
  ASSERT_TRUE(grid.ok());
  auto map = SparseGpMap::Create(*grid, GpParams::PaperPreset(1.0));
  ASSERT_TRUE(map.ok()) << map.status();
  const LargeFieldPlanning large{};
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
