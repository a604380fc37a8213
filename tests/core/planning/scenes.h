// Test worlds of docs/method.md §10 for planner tests: the E1 benchmark, seeded
// random low-/high-rise worlds (E3) and the E4 narrow passage, each with a
// 40 x 40 paper-preset map and a start state.
#pragma once

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/environment/environment.h"
#include "core/mapping/camera.h"
#include "core/mapping/gp_map.h"
#include "core/planning/planner.h"
#include "gtest/gtest.h"

namespace oaipp::testing {

struct Scene {
  std::string name;
  std::unique_ptr<Environment> env;
  std::unique_ptr<GpMap> map;
  UavState start;
  std::vector<int> target_cells;  // ground truth (E1 only)
  // The scene as a planner reads it, the camera's next shot at
  // next_shot_mission_s.
  [[nodiscard]] PlanningContext View(double next_shot_mission_s = 0.0) const {
    return {env.get(), map.get(), DownwardCamera{}, SensorNoise{}, next_shot_mission_s};
  }
};

// Field [-15, 15]^2, flight altitudes [2, 26] m.
inline Aabb FlightVolume() { return {{-15, -15, 2}, {15, 15, 26}}; }

inline std::unique_ptr<GpMap> PaperMap(const Environment& env) {
  auto grid = FieldGrid::FromBounds({-15, -15}, {15, 15}, 0.75);
  EXPECT_TRUE(grid.ok());
  auto map = GpMap::Create(*grid, GpParams::PaperPreset(0.75));
  EXPECT_TRUE(map.ok());
  // Ground under obstacles holds no targets (docs/method.md §2).
  const std::vector<int> covered =
      grid->CellsUnderObstacles([&](const Vec3& p_W) { return env.IsInsideObstacle(p_W); });
  if (!covered.empty()) {
    EXPECT_TRUE(map->FuseNearCertainZeros(covered).ok());
  }
  return std::make_unique<GpMap>(std::move(map).value());
}

inline Scene MakeScene(std::string name, std::vector<Obstacle> obstacles, const Vec3& start) {
  Scene s;
  s.name = std::move(name);
  auto env = Environment::Create(FlightVolume(), {.voxel_size_m = 0.2});
  EXPECT_TRUE(env.ok());
  EXPECT_TRUE(env->Apply({.add = std::move(obstacles)}).ok());
  s.env = std::make_unique<Environment>(std::move(env).value());
  s.map = PaperMap(*s.env);
  s.start.position_W = start;
  return s;
}

// E1: one 4 x 10 x 26 m building centred at (0, -1); 7 people on the lower
// half; start (10, 0, 7) at rest.
inline Scene E1() {
  Scene s = MakeScene("E1", {{"building", Box{{0, -1, 13}, {10, 4, 26}, 0.0}}}, {10, 0, 7});
  const std::vector<Vec2> people{{8, -12}, {-6, -7},  {12, -7}, {-7, -12},
                                 {4, -11}, {-12, -6}, {0, -7}};
  for (const Vec2& p : people) {
    for (int c :
         s.map->grid().CellsOverlapping({p.x() - 0.375, p.y()}, {p.x() + 0.375, p.y() + 2})) {
      s.target_cells.push_back(c);
    }
  }
  return s;
}

// E3: `count` 4 x 4 m buildings, 13 m (low-rise) or 26 m (high-rise) tall,
// at seeded random places at least 3 m from the start (10, 0, 7).
inline Scene RandomWorld(unsigned seed, int count, bool high_rise) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-13, 13);
  const Vec3 start(10, 0, 7);
  const double h = high_rise ? 26.0 : 13.0;
  std::vector<Obstacle> obstacles;
  while (static_cast<int>(obstacles.size()) < count) {
    const Vec2 c(xy(rng), xy(rng));
    if ((c - start.head<2>()).cwiseAbs().maxCoeff() < 2.0 + 3.0) continue;
    obstacles.push_back(
        {absl::StrCat("b", obstacles.size()), Box{{c.x(), c.y(), h / 2}, {4, 4, h}, 0.0}});
  }
  return MakeScene(absl::StrCat(high_rise ? "high" : "low", count), std::move(obstacles), start);
}

// E4: two high-rise walls leave a 3 m passage along x at y in [-1.5, 1.5].
//
//   y ^  #####           walls: x in [-2, 2], y in [1.5, 15] and [-15, -1.5]
//     |  #####
//     |  S ->   (gap)    start (-10, 0, 10)
//     |  #####
//     +------------> x
inline Scene NarrowPassage() {
  return MakeScene("E4",
                   {{"north", Box{{0, 8.25, 13}, {4, 13.5, 26}, 0.0}},
                    {"south", Box{{0, -8.25, 13}, {4, 13.5, 26}, 0.0}}},
                   {-10, 0, 10});
}

}  // namespace oaipp::testing
