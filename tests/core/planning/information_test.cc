#include "core/planning/information.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "absl/strings/str_cat.h"
#include "core/mapping/camera.h"
#include "core/mapping/dense_backend.h"
#include "core/mapping/gp_map.h"
#include "gtest/gtest.h"
#include "tests/support/sanitizers.h"

namespace oaipp {
namespace {

using ::oaipp::testing::UnlessSanitized;

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
// of seeded random paths (a tenth of them under the sanitizers):
// agreement to 1e-9 relative.
TEST_P(InformationAgreementTest, FastEqualsReferenceOnRandomPaths) {
  const GpMap map = RandomPosterior(16, 5);
  const InformationParams params{.kind = GetParam(), .kappa = 1.3};
  const InformationEvaluator fast(map.Mean(), map.Covariance(), params);
  std::mt19937 rng(17);
  int nonzero = 0;
  const int paths = UnlessSanitized(300);
  for (int path = 0; path < paths; ++path) {
    const std::vector<PoseObservation> poses = RandomPoses(map.grid(), rng);
    const double reference = ReferenceInformation(map.Mean(), map.Covariance(), params, poses);
    const double value = fast.Evaluate(poses);
    EXPECT_NEAR(value, reference, 1e-9 * std::abs(reference) + 1e-12) << "path " << path;
    nonzero += reference > 1e-6;
  }
  EXPECT_GT(3 * nonzero, 2 * paths);
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

// Consecutive shots overlap: most of a pose's cells were seen by earlier
// poses of the path (some twice, their noises merged), and the evaluator
// takes those from the inverse of the factor's trailing block rather than
// a solve, except where the noise is far above the variance or a cell is
// listed twice. Agreement with the oracle on both dense backends.
TEST(InformationTest, OverlappingShotsEqualReferenceOnBothBackends) {
  const GpMap map = RandomPosterior(40, 11);
  const DownwardCamera camera;
  const SensorNoise noise;
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> xy(5, 25), h(5, 22), step(-2.0, 2.0);
  absl::StatusOr<DenseBackend> blas = DenseBackend::OpenBlas();
  ASSERT_TRUE(blas.ok()) << blas.status();
  for (const bool open_blas : {false, true}) {
    const DenseBackend backend = open_blas ? *blas : DenseBackend();
    const InformationParams params{.kappa = 1.1, .dense_backend = backend};
    const InformationParams single_params{
        .kappa = 1.1, .single_precision = true, .dense_backend = backend};
    const InformationEvaluator fast(map.Mean(), map.Covariance(), params);
    const InformationEvaluator fast_single(map.Mean(), map.Covariance(), single_params);
    for (int path = 0; path < 4; ++path) {
      // A camera drifting by up to 2 m a shot, with one shot repeated.
      // Paths 2 and 3 also carry a shot with a detector's worst noise
      // (1e4, far above every prior variance) and a cell listed twice.
      Vec3 p(xy(rng), xy(rng), h(rng));
      std::vector<PoseObservation> poses;
      for (int shot = 0; shot < 4; ++shot) {
        if (shot != 2) p += Vec3(step(rng), step(rng), 0.5 * step(rng));
        poses.push_back({camera.FootprintCells(map.grid(), p), noise.Variance(p.z()), p.z(), true});
      }
      if (path >= 2) {
        poses[1].variance = 1e4;
        poses[3].cells.push_back(poses[3].cells.front());
      }
      const double reference = ReferenceInformation(map.Mean(), map.Covariance(), params, poses);
      EXPECT_NEAR(fast.Evaluate(poses), reference, 1e-9 * std::abs(reference))
          << "path " << path << (open_blas ? " on OpenBLAS" : " on Eigen");
      // In single precision (InformationParams::single_precision), where
      // seen cells take the solve above 10 times their variance: to its
      // accuracy.
      const double single = fast_single.Evaluate(poses);
      EXPECT_NEAR(single, reference, 1e-6 * std::abs(reference))
          << "path " << path << (open_blas ? " on OpenBLAS" : " on Eigen") << ", single";
    }
  }
}

// The adaptive objective in single precision
// (InformationParams::single_precision) against the double-precision oracle, on both dense
// backends: within single precision's accuracy (1e-6 relative; 3e-8 was the worst seen, and a wrong
// variance or cell would be off by far more), and not bit for bit double's (the switch took
// effect).
TEST(InformationTest, SinglePrecisionAgreesWithReferenceToItsAccuracy) {
  const GpMap map = RandomPosterior(24, 13);
  const InformationParams params{.kappa = 1.2};
  const DownwardCamera camera;
  const SensorNoise noise;
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> xy(2, 16), h(3, 24), step(-3.0, 3.0);
  std::vector<std::vector<PoseObservation>> paths;
  std::vector<double> references;
  for (int path = 0; path < 8; ++path) {
    Vec3 p(xy(rng), xy(rng), h(rng));
    std::vector<PoseObservation> poses;
    for (int shot = 0; shot < 4; ++shot) {
      p += Vec3(step(rng), step(rng), step(rng));
      p.z() = std::clamp(p.z(), 3.0, 24.0);
      poses.push_back({camera.FootprintCells(map.grid(), p), noise.Variance(p.z()), p.z(), true});
    }
    references.push_back(ReferenceInformation(map.Mean(), map.Covariance(), params, poses));
    ASSERT_GT(references.back(), 0.0);
    paths.push_back(std::move(poses));
  }
  absl::StatusOr<DenseBackend> blas = DenseBackend::OpenBlas();
  ASSERT_TRUE(blas.ok()) << blas.status();
  for (const bool open_blas : {false, true}) {
    InformationParams on_backend = params;
    on_backend.dense_backend = open_blas ? *blas : DenseBackend();
    const InformationEvaluator fast(map.Mean(), map.Covariance(), on_backend);
    InformationParams single_params = on_backend;
    single_params.single_precision = true;
    const InformationEvaluator fast_single(map.Mean(), map.Covariance(), single_params);
    double worst = 0.0;
    int differs = 0;
    for (std::size_t i = 0; i < paths.size(); ++i) {
      const double single = fast_single.Evaluate(paths[i]);
      const double twice = fast.Evaluate(paths[i]);
      worst = std::max(worst, std::abs(single - references[i]) / references[i]);
      differs += single != twice;
    }
    EXPECT_LT(worst, 1e-6) << (open_blas ? "OpenBLAS" : "Eigen");
    EXPECT_GT(differs, 0) << (open_blas ? "OpenBLAS" : "Eigen");
    RecordProperty(open_blas ? "worst_relative_openblas" : "worst_relative_eigen",
                   absl::StrCat(worst));
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
  const int paths = UnlessSanitized(200);
  for (int path = 0; path < paths; ++path) {
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
  EXPECT_EQ(with_prefix, paths - (paths + 3) / 4);
}

// Evaluators over one covariance that share a ConditionedCache condition
// it once per prefix, and value every path bit for bit as an evaluator that
// conditions on its own.
TEST_P(InformationAgreementTest, SharedConditioningEqualsOwnBitForBit) {
  const GpMap map = RandomPosterior(16, 6);
  const InformationParams params{.kind = GetParam(), .kappa = 0.8};
  std::mt19937 rng(41);
  std::vector<PoseObservation> prefix = RandomPoses(map.grid(), rng);
  for (PoseObservation& pose : prefix) pose.scored = false;
  ConditionedCache shared(/*capacity=*/2);
  InformationEvaluator own(map.Mean(), map.Covariance(), params);
  InformationEvaluator first(map.Mean(), map.Covariance(), params);
  InformationEvaluator second(map.Mean(), map.Covariance(), params);
  ASSERT_TRUE(own.Condition(prefix).ok());
  ASSERT_TRUE(first.Condition(prefix, &shared).ok());
  ASSERT_TRUE(second.Condition(prefix, &shared).ok());
  EXPECT_EQ(shared.computations(), 1);
  for (int path = 0; path < 50; ++path) {
    std::vector<PoseObservation> poses = prefix;
    for (PoseObservation pose : RandomPoses(map.grid(), rng)) poses.push_back(std::move(pose));
    const double expected = own.Evaluate(poses);
    EXPECT_EQ(first.Evaluate(poses), expected) << "path " << path;
    EXPECT_EQ(second.Evaluate(poses), expected) << "path " << path;
    const double reference = ReferenceInformation(map.Mean(), map.Covariance(), params, poses);
    EXPECT_NEAR(expected, reference, 1e-9 * std::abs(reference) + 1e-12) << "path " << path;
  }
  // Another prefix (one more pose, or another noise) is another entry.
  std::vector<PoseObservation> longer = prefix;
  longer.push_back(prefix.front());
  ASSERT_TRUE(second.Condition(longer, &shared).ok());
  std::vector<PoseObservation> noisier = prefix;
  noisier.front().variance *= 2.0;
  ASSERT_TRUE(first.Condition(noisier, &shared).ok());
  EXPECT_EQ(shared.computations(), 3);
  std::vector<PoseObservation> poses = noisier;
  for (PoseObservation pose : RandomPoses(map.grid(), rng)) poses.push_back(std::move(pose));
  const double reference = ReferenceInformation(map.Mean(), map.Covariance(), params, poses);
  EXPECT_NEAR(first.Evaluate(poses), reference, 1e-9 * std::abs(reference) + 1e-12);
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
  InformationParams single_params = params;
  single_params.single_precision = true;
  InformationEvaluator plain_single(map.Mean(), map.Covariance(), single_params);
  InformationEvaluator conditioned_single(map.Mean(), map.Covariance(), single_params);
  ASSERT_TRUE(conditioned_single.Condition(prefix).ok());
  double worst_single = 0.0;
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
    for (const auto& [e, e_single] :
         {std::pair{&plain, &plain_single}, std::pair{&conditioned, &conditioned_single}}) {
      // Single precision first: each variance to 2e-6 of the prior's
      // largest (3e-7 seen).
      const Eigen::VectorXd single = e_single->PosteriorVariances(history);
      ASSERT_EQ(single.size(), expected.size());
      const double scale = map.Covariance().diagonal().maxCoeff();
      worst_single = std::max(worst_single, (single - expected).cwiseAbs().maxCoeff() / scale);
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
  EXPECT_LT(worst_single, 2e-6);
  RecordProperty("worst_single_relative_to_prior", absl::StrCat(worst_single));
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
  const auto message = [](const InformationParams& p) {
    return std::string(p.Validate().message());
  };
  EXPECT_NE(message({.confirmation_weight = -0.5}).find("confirmation_weight"), std::string::npos);
  EXPECT_NE(message({.confirmation_weight = INFINITY}).find("confirmation_weight"),
            std::string::npos);
  EXPECT_NE(message({.decision_threshold = 0.0}).find("decision_threshold"), std::string::npos);
  EXPECT_NE(message({.decision_threshold = 1.0}).find("decision_threshold"), std::string::npos);
  EXPECT_NE(message({.kind = ObjectiveKind::kNonAdaptive, .confirmation_weight = 1.0})
                .find("confirmation_weight"),
            std::string::npos);
  EXPECT_TRUE(
      (InformationParams{.confirmation_weight = 2.0, .decision_threshold = 0.3}).Validate().ok());
  EXPECT_NE(message({.confirmation_phase_s = -1}).find("confirmation_phase_s"), std::string::npos);
  EXPECT_NE(message({.confirmation_phase_weight = NAN}).find("confirmation_phase_weight"),
            std::string::npos);
  EXPECT_NE(message({.ambiguity_margin = 0.0}).find("ambiguity_margin"), std::string::npos);
  EXPECT_NE(message({.second_look_weight = -1}).find("second_look_weight"), std::string::npos);
  EXPECT_NE(message({.second_look_weight = INFINITY}).find("second_look_weight"),
            std::string::npos);
  EXPECT_NE(message({.second_look_sharpness = -0.1}).find("second_look_sharpness"),
            std::string::npos);
  EXPECT_NE(message({.second_look_sharpness = NAN}).find("second_look_sharpness"),
            std::string::npos);
  EXPECT_NE(message({.ambiguity_margin = 0.51}).find("ambiguity_margin"), std::string::npos);
  EXPECT_NE(message({.confirmation_preposterior = true}).find("confirmation_preposterior"),
            std::string::npos);
  EXPECT_TRUE((InformationParams{.confirmation_weight = 2.0, .confirmation_preposterior = true})
                  .Validate()
                  .ok());
  EXPECT_NE(message({.kind = ObjectiveKind::kNonAdaptive, .confirmation_phase_s = 10})
                .find("confirmation_phase_s"),
            std::string::npos);
}

// Simpson's rule for f over [a, b] with n (even) intervals.
template <typename F>
double Simpson(const F& f, double a, double b, int n) {
  const double step = (b - a) / n;
  double sum = 0.0;
  for (int i = 0; i <= n; ++i)
    sum += (i == 0 || i == n ? 1 : (i % 2 == 1 ? 4 : 2)) * f(a + i * step);
  return sum * step / 3.0;
}

// The expected misclassification after one observation, integrated directly
// over the measurement y ~ N(mu, v + r): the posterior mean and standard
// deviation follow from the scalar Kalman update, and the posterior
// misclassifies with probability Phi(-|mu' - theta| / sigma'). Simpson's rule
// over +-12 standard deviations, split where mu' = theta (the integrand's
// kink); no Owen's T involved.
double ExpectedMisclassificationAfter(double mu, double v, double r, double theta, int n = 20000) {
  const double sy = std::sqrt(v + r);
  const double gain = v / (v + r);
  const double sigma_post = std::sqrt(v * r / (v + r));
  const auto integrand = [&](double y) {
    const double density = std::exp(-0.5 * std::pow((y - mu) / sy, 2)) / (sy * std::sqrt(2 * kPi));
    const double mu_post = mu + gain * (y - mu);
    return density * 0.5 * std::erfc(std::abs(mu_post - theta) / sigma_post / std::sqrt(2.0));
  };
  const double lo = mu - 12 * sy, hi = mu + 12 * sy;
  const double kink = std::clamp(mu + (theta - mu) / gain, lo, hi);
  return Simpson(integrand, lo, kink, n) + Simpson(integrand, kink, hi, n);
}

TEST(InformationTest, MisclassificationReductionMatchesDirectIntegration) {
  int checked = 0;
  for (double mu : {-0.2, 0.0, 0.1, 0.4, 0.5, 0.57, 0.68, 1.1}) {
    for (double v : {0.01, 0.12, 0.5, 1.82}) {
      for (double r : {0.05, 0.39, 0.73, 3.0}) {
        const double before = 0.5 * std::erfc(std::abs(0.5 - mu) / std::sqrt(v) / std::sqrt(2.0));
        const double expected = before - ExpectedMisclassificationAfter(mu, v, r, 0.5);
        EXPECT_NEAR(MisclassificationReduction(mu, v, r, 0.5), expected, 1e-9)
            << "mu " << mu << " v " << v << " r " << r;
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 128);
  // On the threshold the two straddle with probability arccos(rho) / pi,
  // rho = sqrt(v / (v + r)); a noiseless look removes all of Phi(-|h|).
  const double v = 0.3, r = 0.2;
  EXPECT_NEAR(MisclassificationReduction(0.5, v, r, 0.5),
              0.5 - std::acos(std::sqrt(v / (v + r))) / kPi, 1e-14);
  EXPECT_NEAR(MisclassificationReduction(0.2, v, 0.0, 0.5),
              0.5 * std::erfc(0.3 / std::sqrt(v) / std::sqrt(2.0)), 1e-14);
  EXPECT_EQ(MisclassificationReduction(0.2, 0.0, r, 0.5), 0.0);
}

// The preposterior form integrated directly over the posterior mean m the
// earlier observations leave, m ~ N(mu, p - v) seen from now: after them the
// cell misclassifies with probability Phi(-|m - theta| / sqrt(v)), and after
// this look too with the one-look expectation above, from N(m, v). Simpson's
// rule over +-12 standard deviations, split at m = theta; no Owen's T.
double PreposteriorReductionByIntegration(double mu, double p, double v, double r, double theta) {
  const double sm = std::sqrt(p - v);
  const auto integrand = [&](double m) {
    const double density = std::exp(-0.5 * std::pow((m - mu) / sm, 2)) / (sm * std::sqrt(2 * kPi));
    const double before = 0.5 * std::erfc(std::abs(m - theta) / std::sqrt(v) / std::sqrt(2.0));
    return density * (before - ExpectedMisclassificationAfter(m, v, r, theta, 600));
  };
  const double lo = mu - 12 * sm, hi = mu + 12 * sm;
  const double kink = std::clamp(theta, lo, hi);
  const int n = 300;  // each point integrates a look itself (1e-7 of a finer rule)
  return Simpson(integrand, lo, kink, n) + Simpson(integrand, kink, hi, n);
}

TEST(InformationTest, PreposteriorMisclassificationReductionMatchesDirectIntegration) {
  int checked = 0;
  for (double mu : {0.0, 0.1, 0.4, 0.5, 0.68}) {
    for (const auto& [p, v] : {std::pair{0.12, 0.03}, std::pair{0.12, 0.09}, std::pair{0.5, 0.1},
                               std::pair{1.82, 0.4}}) {
      for (double r : {0.05, 0.39, 3.0}) {
        const double expected = PreposteriorReductionByIntegration(mu, p, v, r, 0.5);
        EXPECT_NEAR(PreposteriorMisclassificationReduction(mu, p, v, r, 0.5), expected, 2e-6)
            << "mu " << mu << " p " << p << " v " << v << " r " << r;
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 60);
  // Nothing learned before this look: the one-look term.
  for (double mu : {0.1, 0.45, 0.7}) {
    EXPECT_NEAR(PreposteriorMisclassificationReduction(mu, 0.2, 0.2, 0.39, 0.5),
                MisclassificationReduction(mu, 0.2, 0.39, 0.5), 1e-14);
  }
  // A second look at a cell one earlier shot will see (variance 0.12 now,
  // noise 0.39). On the threshold the narrowed form values it at 0.144
  // against the first look's 0.161, as if the first look left the cell as
  // undecided as before; seen from now it is worth 0.051, since the first
  // look usually moves the mean off the threshold. At a mean of 0.2 the narrowed form takes the
  // cell as decided (0.0015), while seen from now the first look may move
  // it towards the threshold (0.0147). These figures come from integrating
  // both looks numerically apart from this code.
  const double v = 0.12, after_one = 0.12 * 0.39 / (0.12 + 0.39);
  EXPECT_NEAR(MisclassificationReduction(0.5, v, 0.39, 0.5), 0.1612, 2e-4);
  EXPECT_NEAR(MisclassificationReduction(0.5, after_one, 0.39, 0.5), 0.1438, 2e-4);
  EXPECT_NEAR(PreposteriorMisclassificationReduction(0.5, v, after_one, 0.39, 0.5), 0.0506, 2e-4);
  EXPECT_NEAR(MisclassificationReduction(0.2, after_one, 0.39, 0.5), 0.0015, 2e-4);
  EXPECT_NEAR(PreposteriorMisclassificationReduction(0.2, v, after_one, 0.39, 0.5), 0.0147, 2e-4);
  EXPECT_EQ(PreposteriorMisclassificationReduction(0.4, v, 0.0, 0.39, 0.5), 0.0);
}

// With the same variance, a cell whose mean sits near the threshold (a
// person seen once and missed once: 0.40 on the paper's map) earns more than
// one the map is sure of either way, and a less noisy (lower) shot earns more.
TEST(InformationTest, ConfirmationValuesAmbiguousCellsAndAccurateShots) {
  const double v = 0.12;
  const double ambiguous = MisclassificationReduction(0.40, v, 0.39, 0.5);
  EXPECT_GT(ambiguous, 2 * MisclassificationReduction(0.0, v, 0.39, 0.5));
  EXPECT_GT(ambiguous, 2 * MisclassificationReduction(1.0, v, 0.39, 0.5));
  EXPECT_GT(MisclassificationReduction(0.40, v, 0.22, 0.5), ambiguous);
  // Weight 0 leaves the paper's per-cell value exactly.
  const InformationParams paper{.kappa = 1.0};
  const InformationParams confirm{.kappa = 1.0, .confirmation_weight = 3.0};
  EXPECT_EQ(paper.CellValue(0.4, v, 0.39), 0.4 + std::sqrt(v));
  EXPECT_NEAR(confirm.CellValue(0.4, v, 0.39), 0.4 + std::sqrt(v) + 3.0 * ambiguous, 1e-15);
}

// Scores 150 random paths (a tenth under the sanitizers) with `params` on
// the fast evaluator and the full-update oracle (they must agree), and
// returns how many earn more than under `baseline`, or -1 under the
// sanitizers: a count of a tenth of the paths says nothing, and the
// release stage counts all of them.
int CheckFastAgainstReference(const GpMap& map, const InformationParams& params,
                              const InformationParams& baseline, unsigned seed) {
  const InformationEvaluator fast(map.Mean(), map.Covariance(), params);
  const InformationEvaluator base(map.Mean(), map.Covariance(), baseline);
  std::mt19937 rng(seed);
  int larger = 0;
  for (int path = 0; path < UnlessSanitized(150); ++path) {
    const std::vector<PoseObservation> poses = RandomPoses(map.grid(), rng);
    const double reference = ReferenceInformation(map.Mean(), map.Covariance(), params, poses);
    EXPECT_NEAR(fast.Evaluate(poses), reference, 1e-9 * std::abs(reference) + 1e-12)
        << "path " << path;
    larger += reference > base.Evaluate(poses) + 1e-9;
  }
  return ::oaipp::testing::kSanitized ? -1 : larger;
}

// With the confirmation term the fast evaluator still equals the oracle.
TEST(InformationTest, ConfirmationFastEqualsReference) {
  const GpMap map = RandomPosterior(16, 12);
  const InformationParams params{
      .kappa = 1.0, .confirmation_weight = 4.0, .decision_threshold = 0.45};
  // The term is >= 0 and adds where a scored pose sees cells.
  const int larger = CheckFastAgainstReference(map, params, InformationParams{.kappa = 1.0}, 41);
  if (larger >= 0) {
    EXPECT_GT(larger, 100);
  }
}

// The preposterior form on the fast evaluator equals the oracle, which
// passes each cell's variance before the path; it differs from the plain
// form only where earlier shots of a path see the cell too.
TEST(InformationTest, ConfirmationPreposteriorFastEqualsReference) {
  const GpMap map = RandomPosterior(16, 12);
  const InformationParams plain{
      .kappa = 1.0, .confirmation_weight = 4.0, .decision_threshold = 0.45};
  InformationParams params = plain;
  params.confirmation_preposterior = true;
  const int larger = CheckFastAgainstReference(map, params, plain, 47);
  if (larger >= 0) {
    EXPECT_GT(larger, 20);
  }
}

// The preposterior form reads each cell's variance before the plan, not
// the conditioned prefix's (a team's plan conditions on its teammates'
// pending shots): with a conditioned prefix, Evaluate and the greedy
// start's PoseValue, in double and in single precision, equal the oracle,
// which starts from the unconditioned covariance.
TEST(InformationTest, ConfirmationPreposteriorAfterAConditionedPrefixEqualsReference) {
  const GpMap map = RandomPosterior(16, 15);
  InformationParams params{.kappa = 1.0, .confirmation_weight = 4.0, .decision_threshold = 0.45};
  params.confirmation_preposterior = true;
  InformationParams single = params;
  single.single_precision = true;
  std::mt19937 rng(53);
  std::vector<PoseObservation> prefix = RandomPoses(map.grid(), rng);
  for (PoseObservation& pose : prefix) pose.scored = false;
  InformationEvaluator fast(map.Mean(), map.Covariance(), params);
  InformationEvaluator fast_single(map.Mean(), map.Covariance(), single);
  ASSERT_TRUE(fast.Condition(prefix).ok());
  ASSERT_TRUE(fast_single.Condition(prefix).ok());
  double worst_single = 0.0;
  for (int path = 0; path < UnlessSanitized(100); ++path) {
    std::vector<PoseObservation> poses = prefix;
    for (PoseObservation pose : RandomPoses(map.grid(), rng)) {
      pose.scored = true;
      pose.altitude_m = std::min(pose.altitude_m, 20.0);
      poses.push_back(std::move(pose));
    }
    const double reference = ReferenceInformation(map.Mean(), map.Covariance(), params, poses);
    EXPECT_NEAR(fast.Evaluate(poses), reference, 1e-9 * std::abs(reference) + 1e-12)
        << "path " << path;
    worst_single = std::max(worst_single, std::abs(fast_single.Evaluate(poses) - reference) /
                                              (std::abs(reference) + 1e-12));
    const std::span<const PoseObservation> history(poses.data(), poses.size() - 1);
    const double before = ReferenceInformation(map.Mean(), map.Covariance(), params, history);
    EXPECT_NEAR(fast.PoseValue(poses.back(), fast.PosteriorVariances(history)), reference - before,
                1e-9 * std::abs(reference) + 1e-9)
        << "path " << path;
  }
  EXPECT_LT(worst_single, 1e-6);
}

// The confirmation phase starts when the flight budget left falls to
// confirmation_phase_s: kappa drops to 0 and cells within the margin of the
// threshold earn weight x variance; outside the phase nothing changes.
TEST(InformationTest, ConfirmationPhaseValuesUndecidedCellsInTheLastSeconds) {
  const InformationParams params{.kappa = 1.0,
                                 .confirmation_weight = 100.0,
                                 .confirmation_phase_s = 45.0,
                                 .confirmation_phase_weight = 3000.0,
                                 .ambiguity_margin = 0.25};
  ASSERT_TRUE(params.Validate().ok());
  const InformationParams before = params.ForRemainingBudget(45.5);
  EXPECT_FALSE(before.confirming);
  EXPECT_EQ(before.kappa, 1.0);
  const InformationParams phase = params.ForRemainingBudget(45.0);
  EXPECT_TRUE(phase.confirming);
  EXPECT_EQ(phase.kappa, 0.0);
  // A person seen once and missed once: mean 0.39, variance 0.06; a 12 m
  // shot's noise variance 1 - exp(-0.6).
  const double r = 1.0 - std::exp(-0.6);
  const double tie = 100.0 * MisclassificationReduction(0.39, 0.06, r, 0.5);
  EXPECT_NEAR(before.CellValue(0.39, 0.06, r), 0.39 + std::sqrt(0.06) + tie, 1e-12);
  EXPECT_NEAR(phase.CellValue(0.39, 0.06, r), 0.39 + tie + 3000.0 * 0.06, 1e-12);
  // Unseen (0.1) and confirmed (0.8) cells lie outside the margin: no bonus.
  const double unseen = 100.0 * MisclassificationReduction(0.1, 0.23, r, 0.5);
  EXPECT_NEAR(phase.CellValue(0.1, 0.23, r), 0.1 + unseen, 1e-12);
  const double sure = 100.0 * MisclassificationReduction(0.8, 0.05, r, 0.5);
  EXPECT_NEAR(phase.CellValue(0.8, 0.05, r), 0.8 + sure, 1e-12);
  // The trace objective has no phase.
  const InformationParams trace{.kind = ObjectiveKind::kNonAdaptive};
  EXPECT_FALSE(trace.ForRemainingBudget(0.0).confirming);

  // With a second-look weight, cells outside the margin earn it times their
  // variance in the phase (and nothing before it); undecided cells keep the
  // phase's weight.
  InformationParams looking = params;
  looking.second_look_weight = 1000.0;
  const InformationParams look_phase = looking.ForRemainingBudget(45.0);
  EXPECT_NEAR(look_phase.CellValue(0.1, 0.23, r), 0.1 + unseen + 1000.0 * 0.23, 1e-12);
  EXPECT_NEAR(look_phase.CellValue(0.8, 0.05, r), 0.8 + sure + 1000.0 * 0.05, 1e-12);
  EXPECT_NEAR(look_phase.CellValue(0.39, 0.06, r), 0.39 + tie + 3000.0 * 0.06, 1e-12);
  EXPECT_NEAR(looking.ForRemainingBudget(45.5).CellValue(0.1, 0.23, r),
              0.1 + std::sqrt(0.23) + unseen, 1e-12);

  // With a sharpness alpha = 0.31 a cell outside the margin earns
  // w2 exp(-alpha / variance) instead. Values computed apart (Python's
  // math.exp) for w2 = 11440 at the paper map's prior variance 0.2315 and
  // after one and two "no person" looks from 11.5 m (0.057, 0.038): the
  // looks divide the term by about 60 and 15, where the second divides the
  // variance itself by only 1.5.
  InformationParams sharp = params;
  sharp.second_look_weight = 11440.0;
  sharp.second_look_sharpness = 0.31;
  const InformationParams sharp_phase = sharp.ForRemainingBudget(45.0);
  const auto second_look = [&](double variance) {
    return sharp_phase.CellValue(0.1, variance, r) -
           (0.1 + 100.0 * MisclassificationReduction(0.1, variance, r, 0.5));
  };
  EXPECT_NEAR(second_look(0.2315), 2998.232994729077, 1e-9);
  EXPECT_NEAR(second_look(0.057), 49.71341288756529, 1e-10);
  EXPECT_NEAR(second_look(0.038), 3.27715781879501, 1e-11);
  EXPECT_EQ(second_look(0.0), 0.0);
  // Undecided cells keep the phase's variance weight; before the phase the
  // second look earns nothing.
  EXPECT_NEAR(sharp_phase.CellValue(0.39, 0.06, r), 0.39 + tie + 3000.0 * 0.06, 1e-12);
  EXPECT_NEAR(sharp.ForRemainingBudget(45.5).CellValue(0.1, 0.23, r),
              0.1 + std::sqrt(0.23) + unseen, 1e-12);
}

// In the phase the fast evaluator still equals the oracle, and earns more
// than the same objective without the bonus (kappa 0, no phase) where a path
// sees undecided cells.
TEST(InformationTest, ConfirmationPhaseFastEqualsReference) {
  const GpMap map = RandomPosterior(16, 12);
  const InformationParams params =
      InformationParams{.kappa = 1.0, .confirmation_phase_s = 30.0, .ambiguity_margin = 0.3}
          .ForRemainingBudget(10.0);
  ASSERT_TRUE(params.confirming);
  // The bonus is >= 0 and adds where a pose sees undecided cells.
  const int larger = CheckFastAgainstReference(map, params, InformationParams{.kappa = 0.0}, 43);
  if (larger >= 0) {
    EXPECT_GT(larger, 100);
  }
}

// With a sharp second look the fast evaluator still equals the oracle, and
// earns more than the phase without it wherever a pose sees decided cells.
TEST(InformationTest, SharpSecondLookFastEqualsReference) {
  const GpMap map = RandomPosterior(16, 12);
  const InformationParams phase =
      InformationParams{.kappa = 1.0, .confirmation_phase_s = 30.0, .ambiguity_margin = 0.3}
          .ForRemainingBudget(10.0);
  InformationParams sharp = phase;
  sharp.second_look_weight = 500.0;
  sharp.second_look_sharpness = 0.05;
  ASSERT_TRUE(sharp.Validate().ok());
  const int larger = CheckFastAgainstReference(map, sharp, phase, 44);
  if (larger >= 0) {
    EXPECT_GT(larger, 100);
  }
}

}  // namespace
}  // namespace oaipp
