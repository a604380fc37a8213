#include "core/planning/information.h"

#include <random>

#include "core/mapping/camera.h"
#include "core/mapping/gp_map.h"
#include "gtest/gtest.h"

namespace oaipp {
namespace {

// A posterior (not just the prior): the paper prior on `side` x `side`
// cells after a few seeded random updates, with a random mean.
GpMap RandomPosterior(int side, unsigned seed) {
  auto grid = FieldGrid::Create({0, 0}, side, side, 0.75);
  auto map = GpMap::Create(*grid, GpParams::PaperPreset(0.75));
  EXPECT_TRUE(map.ok());
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> cell(0, side * side - 1);
  std::uniform_real_distribution<double> value(0, 1), var(0.05, 0.8);
  for (int u = 0; u < 5; ++u) {
    std::vector<CellObservation> obs;
    for (int k = 0; k < 30; ++k) obs.push_back({cell(rng), value(rng), var(rng)});
    EXPECT_TRUE(map->Update(obs).ok());
  }
  return std::move(map).value();
}

std::vector<PoseObservation> RandomPoses(const FieldGrid& grid, std::mt19937& rng) {
  std::uniform_int_distribution<int> count(1, 4);
  std::uniform_real_distribution<double> x(grid.min_W().x(), grid.max_W().x()),
      y(grid.min_W().y(), grid.max_W().y()), size(0.5, 12), h(2, 30), var(0.05, 0.8), coin(0, 1);
  std::vector<PoseObservation> poses(static_cast<std::size_t>(count(rng)));
  for (std::size_t i = 0; i < poses.size(); ++i) {
    poses[i].cells = grid.CellsInRectangle({x(rng), y(rng)}, {size(rng), size(rng)});
    poses[i].variance = var(rng);
    poses[i].altitude_m = h(rng);  // some at or above h_sat: fused, never scored
    poses[i].scored = !(i == 0 && coin(rng) < 0.3);
  }
  return poses;
}

class InformationAgreementTest : public ::testing::TestWithParam<ObjectiveKind> {};

// The fast evaluator against the sequential full-update oracle on hundreds
// of seeded random paths: agreement to 1e-9 relative.
TEST_P(InformationAgreementTest, FastEqualsReferenceOnRandomPaths) {
  const GpMap map = RandomPosterior(16, 5);
  const InformationParams params{.kind = GetParam(), .kappa = 1.3};
  const InformationEvaluator fast(map.Mean(), map.Covariance(), params);
  std::mt19937 rng(17);
  int nonzero = 0;
  for (int path = 0; path < 300; ++path) {
    const std::vector<PoseObservation> poses = RandomPoses(map.grid(), rng);
    const double reference = ReferenceInformation(map.Mean(), map.Covariance(), params, poses);
    const double value = fast.Evaluate(poses);
    EXPECT_NEAR(value, reference, 1e-9 * std::abs(reference) + 1e-12) << "path " << path;
    nonzero += reference > 1e-6;
  }
  EXPECT_GT(nonzero, 200);
}

// The same on the full 1600-cell paper map with real camera footprints.
TEST_P(InformationAgreementTest, FastEqualsReferenceOnThePaperMap) {
  const GpMap map = RandomPosterior(40, 9);
  const InformationParams params{.kind = GetParam()};
  const InformationEvaluator fast(map.Mean(), map.Covariance(), params);
  const DownwardCamera camera;
  const SensorNoise noise;
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> xy(0, 30), h(3, 27);
  for (int path = 0; path < 12; ++path) {
    std::vector<PoseObservation> poses(3);
    for (PoseObservation& pose : poses) {
      const Vec3 p(xy(rng), xy(rng), h(rng));
      pose.cells = camera.FootprintCells(map.grid(), p);
      pose.variance = noise.Variance(p.z());
      pose.altitude_m = p.z();
    }
    const double reference = ReferenceInformation(map.Mean(), map.Covariance(), params, poses);
    EXPECT_NEAR(fast.Evaluate(poses), reference, 1e-9 * std::abs(reference)) << "path " << path;
  }
}

// Conditioned on a shared unscored prefix (as every replan is, on the shot
// due at the start): paths that begin with the prefix take the conditioned
// path, others the plain one; both agree with the oracle to 1e-9 relative.
TEST_P(InformationAgreementTest, ConditionedPrefixEqualsReference) {
  const GpMap map = RandomPosterior(16, 6);
  const InformationParams params{.kind = GetParam(), .kappa = 0.8};
  std::mt19937 rng(29);
  std::vector<PoseObservation> prefix = RandomPoses(map.grid(), rng);
  for (PoseObservation& pose : prefix) pose.scored = false;
  InformationEvaluator fast(map.Mean(), map.Covariance(), params);
  ASSERT_TRUE(fast.Condition(prefix).ok());
  int with_prefix = 0;
  for (int path = 0; path < 200; ++path) {
    std::vector<PoseObservation> poses = RandomPoses(map.grid(), rng);
    if (path % 4 != 0) {
      for (PoseObservation& pose : poses) pose.scored = true;
      poses.insert(poses.begin(), prefix.begin(), prefix.end());
      ++with_prefix;
    }
    const double reference = ReferenceInformation(map.Mean(), map.Covariance(), params, poses);
    EXPECT_NEAR(fast.Evaluate(poses), reference, 1e-9 * std::abs(reference) + 1e-12)
        << "path " << path;
  }
  EXPECT_EQ(with_prefix, 150);
}

INSTANTIATE_TEST_SUITE_P(BothObjectives, InformationAgreementTest,
                         ::testing::Values(ObjectiveKind::kAdaptive, ObjectiveKind::kNonAdaptive));

// PosteriorVariances against the oracle's full covariance update, and
// PoseValue(shot, variances) against Evaluate(history + shot), with and
// without a conditioned prefix.
TEST(InformationTest, PosteriorVariancesMatchFullUpdates) {
  const GpMap map = RandomPosterior(16, 8);
  const InformationParams params{.kappa = 1.1};
  std::mt19937 rng(31);
  std::vector<PoseObservation> prefix = RandomPoses(map.grid(), rng);
  for (PoseObservation& pose : prefix) pose.scored = false;
  InformationEvaluator plain(map.Mean(), map.Covariance(), params);
  InformationEvaluator conditioned(map.Mean(), map.Covariance(), params);
  ASSERT_TRUE(conditioned.Condition(prefix).ok());
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<PoseObservation> history = prefix;
    for (PoseObservation pose : RandomPoses(map.grid(), rng)) {
      pose.scored = false;
      history.push_back(std::move(pose));
    }
    Eigen::MatrixXd p = map.Covariance();
    for (const PoseObservation& pose : history) {
      std::vector<CellObservation> obs;
      for (int c : pose.cells) obs.push_back({c, 0.0, pose.variance});
      ASSERT_TRUE(UpdateCovariance(obs, p).ok());
    }
    const Eigen::VectorXd expected = p.diagonal();
    for (const InformationEvaluator* e : {&plain, &conditioned}) {
      const Eigen::VectorXd var = e->PosteriorVariances(history);
      ASSERT_EQ(var.size(), expected.size());
      for (Eigen::Index c = 0; c < var.size(); ++c) EXPECT_NEAR(var[c], expected[c], 1e-12);
      PoseObservation shot = RandomPoses(map.grid(), rng).back();
      shot.scored = true;
      shot.altitude_m = 9.0;
      std::vector<PoseObservation> path = history;
      path.push_back(shot);
      const double reference = ReferenceInformation(map.Mean(), map.Covariance(), params, path);
      EXPECT_NEAR(e->PoseValue(shot, var), reference, 1e-9 * std::abs(reference));
    }
  }
}

TEST(InformationTest, ConditionRejectsAScoredPrefix) {
  const GpMap map = RandomPosterior(8, 3);
  InformationEvaluator e(map.Mean(), map.Covariance(), {});
  PoseObservation pose{.cells = {1, 2}, .variance = 0.3, .altitude_m = 10, .scored = true};
  const absl::Status s = e.Condition({pose});
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("prefix[0].scored"), std::string::npos) << s;
}

// Closed forms on a single cell: prior variance v, mean m, noise r.
//   adaptive, one pose:  (m + kappa sqrt(v)) N(h; 10, 7)
//   two poses: the second sees variance v r / (v + r)
//   non-adaptive: v - v r / (v + r)
TEST(InformationTest, SingleCellClosedForms) {
  const Eigen::VectorXd mean = Eigen::VectorXd::Constant(1, 0.3);
  const Eigen::MatrixXd cov = Eigen::MatrixXd::Constant(1, 1, 0.5);
  const double r = 0.2, h = 12.0;
  const double reward = std::exp(-0.5 * std::pow((h - 10.0) / 7.0, 2)) / (7.0 * std::sqrt(2 * kPi));
  const PoseObservation pose{.cells = {0}, .variance = r, .altitude_m = h};
  const InformationParams adaptive{.kind = ObjectiveKind::kAdaptive, .kappa = 2.0};
  const InformationEvaluator a(mean, cov, adaptive);
  EXPECT_NEAR(a.Evaluate(std::vector{pose}), (0.3 + 2.0 * std::sqrt(0.5)) * reward, 1e-15);
  const double v2 = 0.5 * r / (0.5 + r);
  EXPECT_NEAR(a.Evaluate(std::vector{pose, pose}),
              (0.3 + 2.0 * std::sqrt(0.5)) * reward + (0.3 + 2.0 * std::sqrt(v2)) * reward, 1e-15);
  const InformationEvaluator n(mean, cov, {.kind = ObjectiveKind::kNonAdaptive});
  EXPECT_NEAR(n.Evaluate(std::vector{pose}), 0.5 - v2, 1e-15);
  // At or above h_sat the pose earns nothing.
  const PoseObservation high{.cells = {0}, .variance = r, .altitude_m = 26.0};
  EXPECT_EQ(a.Evaluate(std::vector{high}), 0.0);
  EXPECT_EQ(adaptive.AltitudeReward(26.0), 0.0);
  EXPECT_NEAR(adaptive.AltitudeReward(10.0), 1.0 / (7.0 * std::sqrt(2 * kPi)), 1e-15);
}

TEST(InformationTest, ParamsValidateNamesTheField) {
  EXPECT_FALSE(InformationParams{.kappa = -1}.Validate().ok());
  EXPECT_FALSE(InformationParams{.sigma1_m = 0}.Validate().ok());
  EXPECT_TRUE(InformationParams{}.Validate().ok());
}

}  // namespace
}  // namespace oaipp
