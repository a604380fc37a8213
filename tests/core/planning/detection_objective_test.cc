// The detection objective (docs/method.md §6.6) against sums written out
// here, independently of the evaluator: by hand on two cells, and per cell
// over random paths; and the planner that uses it flying towards a
// probability prior's mass.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/mapping/gp_map.h"
#include "core/planning/information.h"
#include "core/planning/planners.h"
#include "gtest/gtest.h"

namespace oaipp {
namespace {

InformationParams DetectionParams(double discount) {
  InformationParams params;
  params.kind = ObjectiveKind::kDetection;
  params.detection_discount = discount;
  return params;
}

TEST(DetectionObjectiveTest, TwoCellsByHand) {
  const Eigen::VectorXd mean = (Eigen::VectorXd(2) << 0.5, 0.2).finished();
  const Eigen::MatrixXd cov = Eigen::MatrixXd::Identity(2, 2);
  const InformationParams params = DetectionParams(0.9);
  const InformationEvaluator info(mean, cov, params);
  std::vector<PoseObservation> poses(2);
  poses[0].cells = {0, 1};
  poses[0].detection_probability = 0.8;
  poses[1].cells = {1};
  poses[1].detection_probability = 0.5;
  // 0.8 (0.5 + 0.2) + 0.9 * 0.5 * 0.2 * (1 - 0.8) = 0.56 + 0.018
  EXPECT_NEAR(info.Evaluate(poses), 0.578, 1e-15);
  // The first shot unscored (taken where the UAV is): it only leaves cell 1
  // at 0.2 of its mass, and the discount starts at the first scored shot.
  poses[0].scored = false;
  EXPECT_NEAR(info.Evaluate(poses), 0.5 * 0.2 * 0.2, 1e-15);
  // At or above h_sat a shot sees nothing.
  poses[0].scored = true;
  poses[0].altitude_m = params.h_sat_m;
  EXPECT_NEAR(info.Evaluate(poses), 0.9 * 0.5 * 0.2, 1e-15);
}

TEST(DetectionObjectiveTest, EqualsAPerCellSumOnRandomPaths) {
  std::mt19937 rng(7);
  const int n = 200;
  std::uniform_real_distribution<double> value(-0.3, 1.3), unit(0, 1), h(2, 30);
  std::uniform_int_distribution<int> cell(0, n - 1), count(1, 6), size(1, 40);
  Eigen::VectorXd mean(n);
  for (int c = 0; c < n; ++c) mean[c] = value(rng);  // outside [0, 1] too: clamped
  const Eigen::MatrixXd cov = Eigen::MatrixXd::Identity(n, n);
  for (int trial = 0; trial < 200; ++trial) {
    const double discount = 0.5 + 0.5 * unit(rng);
    const InformationParams params = DetectionParams(discount);
    std::vector<PoseObservation> poses(static_cast<std::size_t>(count(rng)));
    for (std::size_t i = 0; i < poses.size(); ++i) {
      std::vector<int> cells;
      for (int k = size(rng); k > 0; --k) cells.push_back(cell(rng));
      std::sort(cells.begin(), cells.end());
      cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
      poses[i].cells = cells;
      poses[i].detection_probability = unit(rng);
      poses[i].altitude_m = h(rng);
      poses[i].scored = !(i == 0 && unit(rng) < 0.3);
    }
    // Cell by cell: the chance it is still unseen before each shot.
    std::vector<double> unseen(n, 1.0);
    double expected = 0.0, weight = 1.0;
    for (const PoseObservation& pose : poses) {
      const double p = pose.altitude_m >= params.h_sat_m ? 0.0 : pose.detection_probability;
      double found = 0.0;
      for (int c : pose.cells) {
        found += std::min(std::max(mean[c], 0.0), 1.0) * unseen[c] * p;
        unseen[c] *= 1.0 - p;
      }
      if (pose.scored) {
        expected += weight * found;
        weight *= discount;
      }
    }
    InformationEvaluator info(mean, cov, params);
    EXPECT_NEAR(info.Evaluate(poses), expected, 1e-12 * std::max(1.0, expected)) << trial;
    // Conditioning on the unscored first shot changes nothing.
    if (!poses[0].scored) {
      ASSERT_TRUE(info.Condition({poses[0]}).ok());
      EXPECT_NEAR(info.Evaluate(poses), expected, 1e-12 * std::max(1.0, expected)) << trial;
    }
  }
}

TEST(DetectionObjectiveTest, DiscountOutsideTheUnitIntervalIsRefused) {
  for (double bad : {0.0, -0.5, 1.5, std::nan("")}) {
    const absl::Status status = DetectionParams(bad).Validate();
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_NE(status.message().find("detection_discount"), std::string::npos) << status;
  }
  EXPECT_TRUE(DetectionParams(1.0).Validate().ok());
}

// A probability prior with its mass in the field's north-east corner (1e-3
// per cell there, 1e-6 elsewhere: a lost-person map's scale): the detection
// objective's first path ends at least twice as near the mass as it
// started, from every seed. (The adaptive objective, whose kappa sigma is a
// thousand times the mass, does not: it fails this from all three seeds.)
TEST(DetectionObjectiveTest, FirstPathHeadsForTheMass) {
  const std::unique_ptr<Environment> env = [] {
    auto e = Environment::Create({{-15, -15, 2}, {15, 15, 26}}, {.voxel_size_m = 0.5});
    return std::make_unique<Environment>(std::move(e).value());
  }();
  auto grid = FieldGrid::FromBounds({-15, -15}, {15, 15}, 0.75);
  ASSERT_TRUE(grid.ok());
  auto prior = GpMap::Create(*grid, GpParams::PaperPreset(0.75));
  ASSERT_TRUE(prior.ok());
  const Vec2 mass_W(10, 10);
  Eigen::VectorXd mean(grid->num_cells());
  for (int c = 0; c < grid->num_cells(); ++c) {
    mean[c] = (grid->CellCentreXY(c) - mass_W).norm() < 5.0 ? 1e-3 : 1e-6;
  }
  auto map = GpMap::FromPrior(*grid, mean, prior->Covariance());
  ASSERT_TRUE(map.ok());
  UavState start;
  start.position_W = {-10, -10, 10};
  const PlanningContext context{env.get(), &*map, DownwardCamera{}, SensorNoise{}};
  const double before = (start.position_W.head<2>() - mass_W).norm();
  for (unsigned seed : {1u, 2u, 3u}) {
    PlannerConfig config{.kind = PlannerKind::kOaIppDetection};
    config.common.seed = seed;
    auto planner = MakePlanner(config);
    ASSERT_TRUE(planner.ok());
    auto path = (*planner)->Plan(context, start, absl::InfiniteFuture());
    ASSERT_TRUE(path.ok()) << path.status();
    const Vec3 end = path->trajectory.Position(path->trajectory.Duration());
    EXPECT_LT((end.head<2>() - mass_W).norm(), 0.5 * before) << "seed " << seed;
  }
}

}  // namespace
}  // namespace oaipp
