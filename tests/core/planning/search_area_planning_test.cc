// A search area in the objectives and the planners (docs/method.md, "Search
// areas"): the fast objectives against values written out here from a
// Kalman filter of the map's own (GpMap::Update), cell by cell; and each
// planner serving the area: OA-IPP looks inside it, the random planner's
// destinations lie in it, the lawnmower covers a concave area with a hole.
#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <vector>

#include "core/mapping/camera.h"
#include "core/mapping/gp_map.h"
#include "core/planning/baseline_planners.h"
#include "core/planning/information.h"
#include "core/planning/planners.h"
#include "gtest/gtest.h"
#include "tests/core/planning/scenes.h"
#include "tests/support/sanitizers.h"

namespace oaipp {
namespace {

using ::oaipp::testing::UnlessSanitized;

// The paper prior on 16 x 16 cells after a few seeded updates.
GpMap Posterior(unsigned seed) {
  auto grid = FieldGrid::Create({0, 0}, 16, 16, 0.75);
  auto map = GpMap::Create(*grid, GpParams::PaperPreset(0.75));
  EXPECT_TRUE(map.ok());
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> cell(0, 255);
  std::uniform_real_distribution<double> value(0, 1), var(0.05, 0.8);
  for (int u = 0; u < 4; ++u) {
    std::vector<CellObservation> obs;
    for (int k = 0; k < 25; ++k) obs.push_back({cell(rng), value(rng), var(rng)});
    EXPECT_TRUE(map->Update(obs).ok());
  }
  return std::move(map).value();
}

// A blob and a strip of the 16 x 16 grid: 1 inside.
std::vector<std::uint8_t> Area(const FieldGrid& grid) {
  std::vector<std::uint8_t> area(static_cast<std::size_t>(grid.num_cells()), 0);
  for (int c = 0; c < grid.num_cells(); ++c) {
    const int row = grid.Row(c), col = grid.Col(c);
    const bool blob = (row - 5) * (row - 5) + (col - 9) * (col - 9) <= 16;
    area[static_cast<std::size_t>(c)] = blob || col <= 2 ? 1 : 0;
  }
  return area;
}

std::vector<PoseObservation> RandomAreaPoses(const FieldGrid& grid, std::mt19937& rng) {
  std::uniform_int_distribution<int> count(1, 4);
  std::uniform_real_distribution<double> x(grid.min_W().x(), grid.max_W().x()),
      y(grid.min_W().y(), grid.max_W().y()), size(0.5, 9), h(2, 30), var(0.05, 0.8);
  std::vector<PoseObservation> poses(static_cast<std::size_t>(count(rng)));
  for (PoseObservation& pose : poses) {
    pose.cells = grid.CellsInRectangle({x(rng), y(rng)}, {size(rng), size(rng)});
    pose.variance = var(rng);
    pose.altitude_m = h(rng);
  }
  return poses;
}

// The objectives over `area` written out with a Kalman filter of the map's
// own: each pose's earning cells valued at the variances the poses before
// it leave (adaptive), or the area's variance before less after
// (non-adaptive).
double Expected(const GpMap& map, const InformationParams& params,
                const std::vector<PoseObservation>& poses, const std::vector<std::uint8_t>& area) {
  GpMap filter = map.Clone();
  auto area_variance = [&](const GpMap& m) {
    double sum = 0.0;
    for (int c = 0; c < m.num_cells(); ++c)
      sum += area[static_cast<std::size_t>(c)] * m.Variance(c);
    return sum;
  };
  const double before = area_variance(filter);
  double total = 0.0;
  for (const PoseObservation& pose : poses) {
    if (params.kind == ObjectiveKind::kAdaptive) {
      double av = 0.0;
      for (int c : pose.cells) {
        if (area[static_cast<std::size_t>(c)] == 0) continue;
        av += params.CellValue(map.Mean()[c], filter.Variance(c), pose.variance);
      }
      total += av * params.AltitudeReward(pose.altitude_m);
    }
    std::vector<CellObservation> obs;
    for (int c : pose.cells) obs.push_back({c, 0.0, pose.variance});
    EXPECT_TRUE(filter.Update(obs).ok());
  }
  return params.kind == ObjectiveKind::kAdaptive ? total : before - area_variance(filter);
}

TEST(AreaObjectiveTest, OnlyTheAreasCellsEarnOnBothObjectives) {
  const GpMap map = Posterior(3);
  const std::vector<std::uint8_t> area = Area(map.grid());
  for (const ObjectiveKind kind : {ObjectiveKind::kAdaptive, ObjectiveKind::kNonAdaptive}) {
    const InformationParams params{.kind = kind, .kappa = 1.2};
    // One evaluator for every path: the non-adaptive one switches to its
    // B A B form after the first dozen or so.
    const InformationEvaluator fast(map.Mean(), map.Covariance(), params, area);
    const InformationEvaluator whole(map.Mean(), map.Covariance(), params);
    std::mt19937 rng(11);
    int less = 0;
    const int paths = UnlessSanitized(60);
    for (int path = 0; path < paths; ++path) {
      const std::vector<PoseObservation> poses = RandomAreaPoses(map.grid(), rng);
      const double expected = Expected(map, params, poses, area);
      EXPECT_NEAR(fast.Evaluate(poses), expected, 1e-9 * std::abs(expected) + 1e-12)
          << static_cast<int>(kind) << " path " << path;
      EXPECT_NEAR(ReferenceInformation(map.Mean(), map.Covariance(), params, poses, area), expected,
                  1e-9 * std::abs(expected) + 1e-12);
      less += fast.Evaluate(poses) < whole.Evaluate(poses) - 1e-9;
    }
    // The area leaves out part of what most paths see.
    EXPECT_GT(2 * less, paths) << static_cast<int>(kind);
  }
}

TEST(AreaObjectiveTest, AWholeAreaChangesNothingAndAnEmptyOneEarnsNothing) {
  const GpMap map = Posterior(4);
  const std::vector<std::uint8_t> all(static_cast<std::size_t>(map.num_cells()), 1);
  const std::vector<std::uint8_t> none(static_cast<std::size_t>(map.num_cells()), 0);
  InformationParams detection;
  detection.kind = ObjectiveKind::kDetection;
  for (const InformationParams& params :
       {InformationParams{.kind = ObjectiveKind::kAdaptive},
        InformationParams{.kind = ObjectiveKind::kNonAdaptive}, detection}) {
    const InformationEvaluator plain(map.Mean(), map.Covariance(), params);
    const InformationEvaluator with_all(map.Mean(), map.Covariance(), params, all);
    const InformationEvaluator with_none(map.Mean(), map.Covariance(), params, none);
    std::mt19937 rng(5);
    for (int path = 0; path < UnlessSanitized(40); ++path) {
      const std::vector<PoseObservation> poses = RandomAreaPoses(map.grid(), rng);
      const double value = plain.Evaluate(poses);
      if (params.kind == ObjectiveKind::kNonAdaptive) {
        // The trace summed column by column rather than whole.
        EXPECT_NEAR(with_all.Evaluate(poses), value, 1e-12 * std::abs(value) + 1e-15);
      } else {
        EXPECT_EQ(with_all.Evaluate(poses), value);
      }
      EXPECT_EQ(with_none.Evaluate(poses), 0.0);
    }
  }
}

TEST(AreaObjectiveTest, DetectionCountsTheMassInsideOnly) {
  const int n = 120;
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> unit(0, 1);
  std::uniform_int_distribution<int> cell(0, n - 1), size(1, 30);
  Eigen::VectorXd mean(n);
  std::vector<std::uint8_t> area(n);
  for (int c = 0; c < n; ++c) {
    mean[c] = unit(rng);
    area[static_cast<std::size_t>(c)] = unit(rng) < 0.4 ? 1 : 0;
  }
  const Eigen::MatrixXd cov = Eigen::MatrixXd::Identity(n, n);
  InformationParams params;
  params.kind = ObjectiveKind::kDetection;
  params.detection_discount = 0.8;
  const InformationEvaluator info(mean, cov, params, area);
  for (int trial = 0; trial < 100; ++trial) {
    std::vector<PoseObservation> poses(3);
    for (PoseObservation& pose : poses) {
      std::set<int> cells;
      for (int k = size(rng); k > 0; --k) cells.insert(cell(rng));
      pose.cells.assign(cells.begin(), cells.end());
      pose.detection_probability = unit(rng);
    }
    std::vector<double> unseen(n, 1.0);
    double expected = 0.0, weight = 1.0;
    for (const PoseObservation& pose : poses) {
      double found = 0.0;
      for (int c : pose.cells) {
        found +=
            area[static_cast<std::size_t>(c)] * mean[c] * unseen[c] * pose.detection_probability;
        unseen[c] *= 1.0 - pose.detection_probability;
      }
      expected += weight * found;
      weight *= params.detection_discount;
    }
    EXPECT_NEAR(info.Evaluate(poses), expected, 1e-12 * std::max(1.0, expected)) << trial;
  }
}

// The E1 field's cells with x < -5 m (a strip along the far side from the
// start at x = 10 m).
std::vector<std::uint8_t> FarStrip(const FieldGrid& grid) {
  std::vector<std::uint8_t> area(static_cast<std::size_t>(grid.num_cells()), 0);
  for (int c = 0; c < grid.num_cells(); ++c) {
    area[static_cast<std::size_t>(c)] = grid.CellCentreXY(c).x() < -5.0 ? 1 : 0;
  }
  return area;
}

TEST(AreaPlannerTest, RandomDestinationsLieInTheArea) {
  const testing::Scene scene = testing::E1();
  const std::vector<std::uint8_t> area = FarStrip(scene.map->grid());
  PlanningContext context = scene.View();
  context.search_area = area;
  for (std::uint32_t seed = 1; seed <= static_cast<std::uint32_t>(UnlessSanitized(20)); ++seed) {
    RandomPlanner planner(PlannerCommon{.seed = seed}, RandomConfig{});
    absl::StatusOr<PlannedPath> path = planner.Plan(context, scene.start, absl::InfiniteFuture());
    ASSERT_TRUE(path.ok()) << path.status();
    const Vec3 destination = path->control_waypoints_W.back();
    const std::optional<int> cell = scene.map->grid().CellOf(destination.head<2>());
    ASSERT_TRUE(cell.has_value()) << seed;
    EXPECT_EQ(area[static_cast<std::size_t>(*cell)], 1) << seed << ": x " << destination.x();
  }
}

// How many of the area's cells the plan's scored shots see.
int AreaCellsSeen(const PlannedPath& path, const FieldGrid& grid,
                  const std::vector<std::uint8_t>& area) {
  const DownwardCamera camera;
  std::set<int> seen;
  for (const MeasurementPose& pose : path.measurement_poses) {
    for (int c : grid.CellsInRectangle(pose.position_W.head<2>(),
                                       camera.FootprintSize(pose.position_W.z()))) {
      if (area[static_cast<std::size_t>(c)] != 0) seen.insert(c);
    }
  }
  return static_cast<int>(seen.size());
}

TEST(AreaPlannerTest, OaIppLooksInsideTheArea) {
  const testing::Scene scene = testing::E1();
  const std::vector<std::uint8_t> area = FarStrip(scene.map->grid());
  PlanningContext with_area = scene.View();
  with_area.search_area = area;
  int more = 0;
  const int seeds = UnlessSanitized(8);
  for (int seed = 1; seed <= seeds; ++seed) {
    PlannerConfig config;
    config.common.seed = static_cast<std::uint32_t>(seed);
    config.oaipp.generations = 8;  // the greedy start and a short refinement
    auto a = MakePlanner(config);
    auto b = MakePlanner(config);
    ASSERT_TRUE(a.ok() && b.ok());
    absl::StatusOr<PlannedPath> inside = (*a)->Plan(with_area, scene.start, absl::InfiniteFuture());
    absl::StatusOr<PlannedPath> anywhere =
        (*b)->Plan(scene.View(), scene.start, absl::InfiniteFuture());
    ASSERT_TRUE(inside.ok()) << inside.status();
    ASSERT_TRUE(anywhere.ok()) << anywhere.status();
    more += AreaCellsSeen(*inside, scene.map->grid(), area) >
            AreaCellsSeen(*anywhere, scene.map->grid(), area);
  }
  EXPECT_EQ(more, seeds);
}

// An L of the E1 field (all but the quarter x > 0, y > 0) with a 6 m square
// hole at (-7, -7), as the api's mask of it would be.
std::vector<std::uint8_t> LWithAHole(const FieldGrid& grid) {
  std::vector<std::uint8_t> area(static_cast<std::size_t>(grid.num_cells()), 0);
  for (int c = 0; c < grid.num_cells(); ++c) {
    const Vec2 p = grid.CellCentreXY(c);
    const bool quarter = p.x() > 0 && p.y() > 0;
    const bool hole = std::abs(p.x() + 7) < 3 && std::abs(p.y() + 7) < 3;
    area[static_cast<std::size_t>(c)] = !quarter && !hole ? 1 : 0;
  }
  return area;
}

TEST(AreaPlannerTest, TheLawnmowerCoversAConcaveAreaWithAHole) {
  const testing::Scene scene = testing::E1();
  const FieldGrid& grid = scene.map->grid();
  const std::vector<std::uint8_t> area = LWithAHole(grid);
  const Aabb box = scene.env->flight_volume().Inflated(-0.5);
  const DownwardCamera camera;
  for (int corner = 0; corner < 4; ++corner) {
    const std::vector<Vec3> pattern =
        LawnmowerPlanner::Pattern(grid, box, camera, 10.0, corner, area);
    ASSERT_GE(pattern.size(), 2u);
    // The footprints along the pattern, sampled every 0.25 m.
    std::set<int> covered;
    for (std::size_t i = 0; i + 1 < pattern.size(); ++i) {
      const int steps = 1 + static_cast<int>((pattern[i + 1] - pattern[i]).norm() / 0.25);
      for (int s = 0; s <= steps; ++s) {
        const Vec3 p = pattern[i] + (pattern[i + 1] - pattern[i]) * (double(s) / steps);
        for (int c : grid.CellsInRectangle(p.head<2>(), camera.FootprintSize(10.0))) {
          covered.insert(c);
        }
      }
    }
    int inside = 0, seen = 0;
    for (int c = 0; c < grid.num_cells(); ++c) {
      if (area[static_cast<std::size_t>(c)] == 0) continue;
      ++inside;
      seen += covered.count(c) > 0;
    }
    EXPECT_GE(seen, 0.95 * inside) << "corner " << corner << ": " << seen << " of " << inside;
    // The quarter outside the L gets no lane of its own: no point of the
    // pattern lies more than half a footprint inside it.
    for (const Vec3& p : pattern) {
      EXPECT_TRUE(box.Contains(p, 1e-9));
      EXPECT_FALSE(p.x() > 4.2 && p.y() > 5.8) << p.transpose();
    }
  }
}

}  // namespace
}  // namespace oaipp
