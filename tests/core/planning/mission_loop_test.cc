// A small in-process mission loop on the E1 world (docs/method.md §7.6):
// plan, fly, take noise-free ground-truth measurements at the sensor rate,
// fuse, replan until the 150 s budget is spent.
#include <cmath>

#include "core/planning/planners.h"
#include "gtest/gtest.h"
#include "tests/core/planning/scenes.h"

namespace oaipp {
namespace {

// RSE = sqrt(sum over cells (mu - truth)^2), the paper's metric.
double Rse(const GpMap& map, const std::vector<int>& targets) {
  Eigen::VectorXd truth = Eigen::VectorXd::Zero(map.num_cells());
  for (int c : targets) truth[c] = 1.0;
  return (map.Mean() - truth).norm();
}

// Flies one mission and returns the final RSE.
double FlyMission(PlannerKind kind, std::uint32_t seed, double budget_s = 150.0) {
  testing::Scene scene = testing::E1();
  PlannerConfig config{.kind = kind};
  config.common.seed = seed;
  config.oaipp.generations = 20;
  auto planner = MakePlanner(config);
  EXPECT_TRUE(planner.ok());
  Eigen::VectorXd truth = Eigen::VectorXd::Zero(scene.map->num_cells());
  for (int c : scene.target_cells) truth[c] = 1.0;

  UavState state = scene.start;
  const DownwardCamera camera;
  const SensorNoise noise;
  int measurements = 0;
  PlanningContext context = scene.View();
  while (state.mission_time_s < budget_s) {
    context.remaining_budget_s = budget_s - state.mission_time_s;
    absl::StatusOr<PlannedPath> path = (*planner)->Plan(context, state, absl::InfiniteFuture());
    EXPECT_TRUE(path.ok()) << path.status();
    if (!path.ok()) break;
    const double fly_s = std::min(path->trajectory.Duration(), budget_s - state.mission_time_s);
    for (const MeasurementPose& pose : path->measurement_poses) {
      if (pose.t_s > fly_s) break;
      const std::vector<int> cells =
          camera.VisibleFootprintCells(scene.map->grid(), pose.position_W, scene.env.get());
      std::vector<double> labels;
      for (int c : cells) labels.push_back(truth[c]);
      auto obs = LabelsToObservations(scene.map->grid(), noise, pose.position_W.z(), cells, labels);
      EXPECT_TRUE(obs.ok());
      EXPECT_TRUE(scene.map->Update(*obs).ok());
      ++measurements;
    }
    state = StateAlong(path->trajectory, fly_s, state.mission_time_s);
    context.next_shot_mission_s = path->next_shot_mission_s;
  }
  EXPECT_GE(measurements, 20);  // 150 s at 0.15 Hz: 22 or 23 shots
  return Rse(*scene.map, scene.target_cells);
}

TEST(MissionLoopTest, StartingErrorMatchesReference) {
  const testing::Scene scene = testing::E1();
  // docs/reference-values.md: 48 target cells; RSE0 = 7.375636 with prior mean 0.1.
  EXPECT_EQ(scene.target_cells.size(), 48u);
  Eigen::VectorXd prior = Eigen::VectorXd::Constant(scene.map->num_cells(), 0.1);
  Eigen::VectorXd truth = Eigen::VectorXd::Zero(scene.map->num_cells());
  for (int c : scene.target_cells) truth[c] = 1.0;
  EXPECT_NEAR((prior - truth).norm(), 7.375636, 1e-6);
}

TEST(MissionLoopTest, AdaptiveOaIppBeatsRandomOnEverySeed) {
  for (std::uint32_t seed = 1; seed <= 5; ++seed) {
    const double oaipp = FlyMission(PlannerKind::kOaIpp, seed);
    const double random = FlyMission(PlannerKind::kRandom, seed);
    EXPECT_LT(oaipp, random) << "seed " << seed;
    EXPECT_LT(oaipp, 7.0) << "seed " << seed;  // and it reduced the error
  }
}

}  // namespace
}  // namespace oaipp
