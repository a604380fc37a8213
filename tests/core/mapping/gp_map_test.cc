#include "core/mapping/gp_map.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "Eigen/Cholesky"
#include "Eigen/Eigenvalues"
#include "Eigen/LU"
#include "core/common/geometry.h"
#include "core/mapping/camera.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/mapping/centred_grid.h"

namespace oaipp {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using ::testing::HasSubstr;

// docs/reference-values.md §1 tolerances are 1e-6 relative.
void ExpectRel(double actual, double expected, double rel = 1e-6) {
  EXPECT_NEAR(actual, expected, rel * std::abs(expected));
}

// The block rows 15..24, cols 13..26 of the 40 x 40 grid (docs/reference-values.md).
std::vector<CellObservation> Block140(double variance, double value = 1.0) {
  std::vector<CellObservation> obs;
  for (int row = 15; row <= 24; ++row) {
    for (int col = 13; col <= 26; ++col) {
      obs.push_back({.cell = row * 40 + col, .value = value, .variance = variance});
    }
  }
  return obs;
}

// Textbook dense formulas (no Cholesky, no merging), the brute-force twin.
MatrixXd KernelMatrix(const FieldGrid& grid, const GpParams& p) {
  const int n = grid.num_cells();
  MatrixXd k(n, n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      k(i, j) = Matern32((grid.CellCentreXY(i) - grid.CellCentreXY(j)).norm(), p.length_scale_m,
                         p.signal_var);
    }
  }
  return k;
}

MatrixXd DensePrior(const FieldGrid& grid, const GpParams& p) {
  const MatrixXd k = KernelMatrix(grid, p);
  const MatrixXd a = k + p.noise_var * MatrixXd::Identity(k.rows(), k.cols());
  return k - k * a.partialPivLu().solve(k);
}

TEST(MaternKernelTest, MatchesReferenceUnitParameters) {
  const double d[] = {0, 0.5, 1, 2, 3};
  const double k[] = {1, 0.784887654, 0.4833577246, 0.1397313502, 0.0343132432};
  for (int i = 0; i < 5; ++i) ExpectRel(Matern32(d[i], 1.0, 1.0), k[i]);
}

TEST(MaternKernelTest, MatchesReferencePaperParameters) {
  const double d[] = {0, 1, 2, 3, 4};
  const double k[] = {1.8221188, 1.6729851, 1.3781058, 1.0682746, 0.7964925};
  // docs/reference-values.md gives these to 8 significant digits.
  for (int i = 0; i < 5; ++i) ExpectRel(Matern32(d[i], std::exp(1.3), std::exp(0.6)), k[i], 1e-7);
}

TEST(GpParamsTest, PaperPresetAndDefaults) {
  const GpParams p = GpParams::PaperPreset(0.75);
  ExpectRel(p.length_scale_m, 2.751973);
  ExpectRel(p.signal_var, 1.822119);
  ExpectRel(p.noise_var, 2.013753);
  EXPECT_EQ(p.prior_mean, 0.1);
  const GpParams d;
  EXPECT_DOUBLE_EQ(d.length_scale_m, p.length_scale_m);
  EXPECT_DOUBLE_EQ(d.signal_var, p.signal_var);
  EXPECT_DOUBLE_EQ(d.noise_var, p.noise_var);
  EXPECT_TRUE(d.Validate().ok());
  EXPECT_THAT(GpParams{.noise_var = 0}.Validate().message(), HasSubstr("noise_var"));
  EXPECT_THAT(GpParams{.prior_mean = NAN}.Validate().message(), HasSubstr("prior_mean"));
}

// (1 - p) / p with p = 0.95 exp(-((h - 10) / 7)^2 / 2), evaluated by hand
// (Python's math module) at the best altitude, one width either side, the
// paper's lowest altitude and its saturation altitude.
TEST(SensorNoiseTest, DetectorNoiseFollowsTheDetectorsAccuracyCurve) {
  SensorNoise noise;
  ExpectRel(noise.Variance(10.0), 0.393469340);  // unset: the paper's A (1 - exp(-B h))
  noise.detector = DetectorAccuracy{};
  EXPECT_TRUE(noise.Validate().ok());
  ExpectRel(noise.Variance(10.0), 0.052631578947368474, 1e-13);
  ExpectRel(noise.detector->DetectionProbability(17.0), 0.5762041267270017, 1e-13);
  ExpectRel(noise.Variance(17.0), 0.7354960744211876, 1e-13);
  ExpectRel(noise.Variance(3.0), 0.7354960744211876, 1e-13);
  ExpectRel(noise.Variance(2.0), 1.0225407516150768, 1e-13);  // the paper's model: 0.0952
  ExpectRel(noise.Variance(26.0), 13.346961711214805, 1e-13);
  ExpectRel(noise.Variance(45.0), 282459.30160092044, 1e-10);  // p = 3.54e-6, below the cap
  // Where the detector sees (almost) nothing, a label changes (almost)
  // nothing: at 50 m (1 - p) / p would be 1.297e7.
  EXPECT_EQ(noise.Variance(50.0), DetectorAccuracy::kMaxVariance);
  EXPECT_EQ(noise.Variance(500.0), DetectorAccuracy::kMaxVariance);
  EXPECT_EQ(noise.Variance(-1e300), DetectorAccuracy::kMaxVariance);

  auto with = [](auto edit) {
    SensorNoise n;
    n.detector = DetectorAccuracy{};
    edit(*n.detector);
    return std::string(n.Validate().message());
  };
  EXPECT_THAT(with([](auto& d) { d.p_max = 1.0; }),
              HasSubstr("detector.p_max: must lie in (0, 1)"));
  EXPECT_THAT(with([](auto& d) { d.h_best_m = INFINITY; }), HasSubstr("detector.h_best_m"));
  EXPECT_THAT(with([](auto& d) { d.h_best_m = -1; }), HasSubstr("detector.h_best_m: must be >= 0"));
  EXPECT_TRUE(std::isnan(noise.Variance(NAN)));
  EXPECT_THAT(with([](auto& d) { d.width_m = -1; }), HasSubstr("detector.width_m"));
  for (const double q : {0.0, 1.0, -0.1, double{NAN}}) {
    EXPECT_THAT(with([q](auto& d) { d.false_positive_rate = q; }),
                HasSubstr("detector.false_positive_rate: must lie in (0, 1)"))
        << q;
  }
  // Without a false-positive rate both labels get (1 - p) / p.
  ExpectRel(noise.LabelVariance(10.0, 1.0), 0.052631578947368474, 1e-13);
  ExpectRel(noise.LabelVariance(17.0, 0.0), 0.7354960744211876, 1e-13);
}

// With a false-positive rate q each label moves a cell's log-odds by the
// detector's likelihood ratio: v_detection = 1 / (2 ln(p / q)), v_miss =
// 1 / (2 ln((1 - q) / (1 - p))). Reference values computed independently.
TEST(SensorNoiseTest, FalsePositiveRateWeighsDetectionsAndMissesByTheirLikelihoodRatios) {
  SensorNoise noise;
  noise.detector = DetectorAccuracy{.false_positive_rate = 0.01};
  ASSERT_TRUE(noise.Validate().ok());
  ExpectRel(noise.LabelVariance(10.0, 1.0), 0.10979655618759297, 1e-13);  // p = 0.95
  ExpectRel(noise.LabelVariance(10.0, 0.0), 0.16746592920245543, 1e-13);
  ExpectRel(noise.LabelVariance(17.0, 1.0), 0.12333872324440305, 1e-13);  // p = 0.5762
  ExpectRel(noise.LabelVariance(17.0, 0.0), 0.58930781021799, 1e-13);
  // A label >= 0.5 counts as a detection; a planned shot is a miss.
  EXPECT_EQ(noise.LabelVariance(10.0, 0.5), noise.LabelVariance(10.0, 1.0));
  EXPECT_EQ(noise.LabelVariance(10.0, 0.49), noise.LabelVariance(10.0, 0.0));
  EXPECT_EQ(noise.Variance(10.0), noise.LabelVariance(10.0, 0.0));
  // A frequent false positive makes a detection weigh less than a miss.
  noise.detector->false_positive_rate = 0.6;
  ExpectRel(noise.LabelVariance(10.0, 1.0), 1.0880627282008561, 1e-13);
  ExpectRel(noise.LabelVariance(10.0, 0.0), 0.24044917348149397, 1e-13);
  // Where p(h) <= q (p(26 m) = 0.0697 < 0.1) a label tells nothing.
  noise.detector->false_positive_rate = 0.1;
  EXPECT_EQ(noise.LabelVariance(26.0, 1.0), DetectorAccuracy::kMaxVariance);
  EXPECT_EQ(noise.LabelVariance(26.0, 0.0), DetectorAccuracy::kMaxVariance);
  EXPECT_EQ(noise.LabelVariance(500.0, 1.0), DetectorAccuracy::kMaxVariance);
  EXPECT_TRUE(std::isnan(noise.LabelVariance(NAN, 1.0)));
  // q just below p: ln(p / q) = 1e-7 would give 5e6, above the cap; the
  // miss's 1 / (2 ln(1 + 1.9e-6)) = 2.6e5 is not.
  noise.detector->false_positive_rate = 0.95 * (1 - 1e-7);
  EXPECT_EQ(noise.LabelVariance(10.0, 1.0), DetectorAccuracy::kMaxVariance);
  ExpectRel(noise.LabelVariance(10.0, 0.0), 1.0 / (2 * std::log1p(0.95e-7 / 0.05)), 1e-6);
  // The paper's model has one variance for both labels: 1 - e^-0.5.
  const SensorNoise paper;
  ExpectRel(paper.LabelVariance(10.0, 1.0), 0.393469340, 1e-8);
  ExpectRel(paper.LabelVariance(10.0, 0.0), 0.393469340, 1e-8);
}

// docs/reference-values.md §3 (1-D GP): kernel 2.0 * Matern32(l = 1.5), noise 0.1, X = [0, 1, 3],
// y = [1, -1, 0.5], x* = [0.5, 2, 5]. Checked twice: with the textbook
// formulas, and as a Kalman update of a map whose prior is K.
TEST(GpPosteriorTest, OneDimensionalReference) {
  const double mean_ref[] = {-0.0249323714, -0.456926368, 0.2403414202};
  const double var_ref[] = {0.18489935, 0.6437667559, 1.7891775238};
  const std::vector<double> x = {0, 1, 3}, y = {1, -1, 0.5}, xs = {0.5, 2, 5};
  auto k = [](double a, double b) { return Matern32(std::abs(a - b), 1.5, 2.0); };

  MatrixXd kxx(3, 3), ksx(3, 3);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      kxx(i, j) = k(x[i], x[j]) + (i == j ? 0.1 : 0.0);
      ksx(i, j) = k(xs[i], x[j]);
    }
  }
  const VectorXd alpha = kxx.ldlt().solve(Eigen::Map<const VectorXd>(y.data(), 3));
  const MatrixXd v = kxx.ldlt().solve(ksx.transpose());
  for (int i = 0; i < 3; ++i) {
    ExpectRel(ksx.row(i).dot(alpha), mean_ref[i]);
    ExpectRel(k(xs[i], xs[i]) - ksx.row(i).dot(v.col(i)), var_ref[i]);
  }

  // A 1 x 11 grid with centres at x = 0, 0.5, ..., 5.
  auto grid = FieldGrid::Create(Vec2(-0.25, -0.25), 11, 1, 0.5);
  ASSERT_TRUE(grid.ok());
  MatrixXd prior(11, 11);
  for (int i = 0; i < 11; ++i) {
    for (int j = 0; j < 11; ++j) prior(i, j) = k(0.5 * i, 0.5 * j);
  }
  auto map = GpMap::FromPrior(*grid, VectorXd::Zero(11), prior);
  ASSERT_TRUE(map.ok()) << map.status();
  const std::vector<CellObservation> obs = {{.cell = 0, .value = 1, .variance = 0.1},
                                            {.cell = 2, .value = -1, .variance = 0.1},
                                            {.cell = 6, .value = 0.5, .variance = 0.1}};
  ASSERT_TRUE(map->Update(obs).ok());
  const int star[] = {1, 4, 10};
  for (int i = 0; i < 3; ++i) {
    ExpectRel(map->Mean()[star[i]], mean_ref[i]);
    ExpectRel(map->Variance(star[i]), var_ref[i]);
  }
}

// Shared 1600-cell paper map: the prior is built once for the suite.
class PaperMapTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const auto start = std::chrono::steady_clock::now();
    auto map = GpMap::Create(testing::CentredGrid(40, 40, 0.75), GpParams::PaperPreset(0.75));
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ASSERT_TRUE(map.ok()) << map.status();
    ::testing::Test::RecordProperty("prior_1600_cells_s", std::to_string(seconds));
    map_ = new GpMap(std::move(map).value());
  }
  static void TearDownTestSuite() {
    delete map_;
    map_ = nullptr;
  }
  static const GpMap& Map() { return *map_; }

 private:
  static GpMap* map_;
};
GpMap* PaperMapTest::map_ = nullptr;

TEST_F(PaperMapTest, PriorTraceAndDiagonalMatchReference) {
  const GpMap& map = Map();
  ExpectRel(map.Trace(), 387.319924);
  EXPECT_NEAR(map.Covariance().diagonal().minCoeff(), 0.231517, 5e-7);
  EXPECT_NEAR(map.Covariance().diagonal().maxCoeff(), 0.456205, 5e-7);
  EXPECT_TRUE(map.Covariance() == map.Covariance().transpose()) << "P0 must be exactly symmetric";
  EXPECT_TRUE((map.Mean().array() == 0.1).all());
}

TEST_F(PaperMapTest, OneUpdateTracesMatchReference) {
  const double var_low = 0.05 * (1 - std::exp(-2.0));
  const double var_10m = SensorNoise{}.Variance(10.0);
  ExpectRel(var_low, 0.043233236);
  ExpectRel(var_10m, 0.393469340);
  for (auto [var, trace] : {std::pair{var_low, 351.422991}, std::pair{var_10m, 363.636877}}) {
    GpMap map = Map().Clone();
    ASSERT_TRUE(map.Update(Block140(var)).ok());
    ExpectRel(map.Trace(), trace);
    EXPECT_TRUE(map.Covariance() == map.Covariance().transpose());
    // The cheap predictions agree with the full update.
    auto predicted = TraceAfterUpdate(Map().Covariance(), Block140(var));
    ASSERT_TRUE(predicted.ok());
    ExpectRel(*predicted, trace);
    auto variances = VariancesAfterUpdate(Map().Covariance(), Block140(var));
    ASSERT_TRUE(variances.ok());
    EXPECT_LT((*variances - map.Variances()).cwiseAbs().maxCoeff(), 1e-12);
    MatrixXd p = Map().Covariance();
    ASSERT_TRUE(UpdateCovariance(Block140(var, /*value=*/0.0), p).ok());
    EXPECT_LT((p - map.Covariance()).cwiseAbs().maxCoeff(), 1e-15);
  }
}

// How much evidence a person needs before the map mean on it passes 0.5
// (E5's "found"). One 0.75 x 2 m person at (-10, -10); shots from altitude h
// see the cells whose centres lie within h tan(22.5 deg) x h tan(30 deg) of
// the shot's centre (offsets (0, 1), (1, 1.5), (-1, 0.5), (0.5, 2) m from
// the person's corner) and label the 8 cells the person overlaps 1 when
// detected, everything else 0. Expected: the largest mean on the person
// after the sequence, from an independent dense computation of the same
// model (numpy, np.linalg.solve on the full 1600-cell matrices).
TEST_F(PaperMapTest, DetectionsAndMissesOfOnePersonMatchAnIndependentComputation) {
  const FieldGrid grid = testing::CentredGrid(40, 40, 0.75);
  const std::vector<int> person = grid.CellsOverlapping(Vec2(-10.375, -10), Vec2(-9.625, -8));
  ASSERT_EQ(person.size(), 8u);
  const Vec2 offsets[4] = {{0, 1}, {1, 1.5}, {-1, 0.5}, {0.5, 2}};
  struct Case {
    double altitude_m;
    std::vector<bool> detected;
    double max_mean;
  };
  const std::vector<Case> cases = {
      {10.0, {true}, 0.678433},
      {10.0, {true, false}, 0.401198},
      {10.0, {true, true}, 0.793366},
      {10.0, {true, true, false}, 0.567360},
      {10.0, {true, true, false, false}, 0.442559},
      {10.0, {true, true, true, false}, 0.661481},
      {11.5, {true}, 0.658761},
      {11.5, {true, false}, 0.393710},
      {11.5, {true, true, false}, 0.558740},
      {11.5, {true, true, false, false}, 0.437147},
  };
  const double tan_x = std::tan(DegToRad(22.5)), tan_y = std::tan(DegToRad(30.0));
  for (const Case& c : cases) {
    GpMap map = Map().Clone();
    for (std::size_t shot = 0; shot < c.detected.size(); ++shot) {
      const Vec2 centre = Vec2(-10, -10) + offsets[shot];
      std::vector<int> cells;
      std::vector<double> labels;
      for (int i = 0; i < grid.num_cells(); ++i) {
        const Vec2 d = grid.CellCentreXY(i) - centre;
        if (std::abs(d.x()) > c.altitude_m * tan_x || std::abs(d.y()) > c.altitude_m * tan_y) {
          continue;
        }
        cells.push_back(i);
        const bool on_person = std::binary_search(person.begin(), person.end(), i);
        labels.push_back(on_person && c.detected[shot] ? 1.0 : 0.0);
      }
      auto obs = LabelsToObservations(grid, SensorNoise{}, c.altitude_m, cells, labels);
      ASSERT_TRUE(obs.ok()) << obs.status();
      ASSERT_TRUE(map.Update(*obs).ok());
    }
    double max_mean = -1;
    for (int i : person) max_mean = std::max(max_mean, map.Mean()[i]);
    EXPECT_NEAR(max_mean, c.max_mean, 2e-6)
        << "h = " << c.altitude_m << ", shots = " << c.detected.size();
  }
}

TEST_F(PaperMapTest, OriginalIsUntouchedByUpdatesOfAClone) {
  const double trace = Map().Trace();
  GpMap clone = Map().Clone();
  ASSERT_TRUE(clone.Update(Block140(0.1)).ok());
  EXPECT_EQ(Map().Trace(), trace);
  EXPECT_LT(clone.Trace(), trace);
}

TEST(GpMapTest, CopyPolicyIsExplicit) {
  static_assert(!std::is_copy_constructible_v<GpMap>);
  static_assert(!std::is_copy_assignable_v<GpMap>);
  static_assert(std::is_nothrow_move_constructible_v<GpMap>);
  static_assert(std::is_nothrow_move_assignable_v<GpMap>);
}

// docs/reference-values.md: the paper's printed numbers read literally (l = 3.67 m,
// sn2 = 1.42, sf2 = 1.82) give a different prior.
TEST(PriorCovarianceTest, LiteralPaperNumbersGiveReferenceTrace) {
  auto p0 = PriorCovariance(testing::CentredGrid(40, 40, 0.75),
                            {.length_scale_m = 3.67, .signal_var = 1.82, .noise_var = 1.42});
  ASSERT_TRUE(p0.ok());
  ExpectRel(p0->trace(), 235.606822);
}

// More cells than the 128-column panels of the blocked inverse, and an
// uneven grid, against the textbook formula.
TEST(PriorCovarianceTest, MatchesDenseFormulaOnSmallGrids) {
  for (auto [nx, ny, res] :
       {std::tuple{15, 12, 0.75}, std::tuple{7, 3, 2.0}, std::tuple{1, 1, 1.0}}) {
    const FieldGrid grid = testing::CentredGrid(nx, ny, res);
    const GpParams p = GpParams::PaperPreset(0.75);
    auto p0 = PriorCovariance(grid, p);
    ASSERT_TRUE(p0.ok());
    EXPECT_LT((*p0 - DensePrior(grid, p)).cwiseAbs().maxCoeff(), 1e-12) << nx << " x " << ny;
    EXPECT_TRUE(*p0 == p0->transpose());
  }
}

std::vector<CellObservation> RandomObservations(std::mt19937& rng, int n, int count) {
  std::uniform_int_distribution<int> cell(0, n - 1);
  std::uniform_real_distribution<double> value(0, 1), log_var(std::log(1e-3), std::log(1.0));
  std::vector<CellObservation> obs;
  for (int i = 0; i < count; ++i) {
    obs.push_back({.cell = cell(rng), .value = value(rng), .variance = std::exp(log_var(rng))});
  }
  return obs;
}

// Brute-force Kalman update with an explicit inverse, observations unmerged.
void DenseUpdate(const std::vector<CellObservation>& obs, VectorXd& mu, MatrixXd& p) {
  const int m = static_cast<int>(obs.size());
  MatrixXd h = MatrixXd::Zero(m, p.rows());
  VectorXd z(m);
  MatrixXd r = MatrixXd::Zero(m, m);
  for (int k = 0; k < m; ++k) {
    h(k, obs[k].cell) = 1.0;
    z[k] = obs[k].value;
    r(k, k) = obs[k].variance;
  }
  const MatrixXd s = h * p * h.transpose() + r;
  const MatrixXd w = p * h.transpose() * s.inverse();
  mu += w * (z - h * mu);
  p -= w * h * p;
}

TEST(GpMapTest, UpdateMatchesDenseKalmanAndSequentialUpdates) {
  const FieldGrid grid = testing::CentredGrid(12, 10, 0.75);
  auto base = GpMap::Create(grid, GpParams::PaperPreset(0.75));
  ASSERT_TRUE(base.ok());
  std::mt19937 rng(42);
  for (int trial = 0; trial < 5; ++trial) {
    // 60 readings over 120 cells: many cells are observed more than once.
    const std::vector<CellObservation> obs = RandomObservations(rng, grid.num_cells(), 60);

    GpMap merged = base->Clone();
    ASSERT_TRUE(merged.Update(obs).ok());

    GpMap sequential = base->Clone();
    for (const CellObservation& o : obs) ASSERT_TRUE(sequential.Update({&o, 1}).ok());

    VectorXd mu = base->Mean();
    MatrixXd p = base->Covariance();
    DenseUpdate(obs, mu, p);

    EXPECT_LT((merged.Covariance() - sequential.Covariance()).cwiseAbs().maxCoeff(), 1e-10);
    EXPECT_LT((merged.Mean() - sequential.Mean()).cwiseAbs().maxCoeff(), 1e-10);
    EXPECT_LT((merged.Covariance() - p).cwiseAbs().maxCoeff(), 1e-10);
    EXPECT_LT((merged.Mean() - mu).cwiseAbs().maxCoeff(), 1e-10);
  }
}

// The deferred update is the same update in two halves: the mean at once
// and bit for bit, the trace at once to rounding (against the brute-force
// twin), and once settled the covariance bit for bit; a second update
// settles the first before it starts, and a clone carries what is pending.
TEST(GpMapTest, DeferredUpdatesSettleToTheSameMapBitForBit) {
  const FieldGrid grid = testing::CentredGrid(12, 10, 0.75);
  auto base = GpMap::Create(grid, GpParams::PaperPreset(0.75));
  ASSERT_TRUE(base.ok());
  std::mt19937 rng(7);
  GpMap whole = base->Clone();
  GpMap deferred = base->Clone();
  VectorXd mu = base->Mean();
  MatrixXd p = base->Covariance();
  for (int shot = 0; shot < 4; ++shot) {
    const std::vector<CellObservation> obs = RandomObservations(rng, grid.num_cells(), 25);
    ASSERT_TRUE(whole.Update(obs).ok());
    ASSERT_TRUE(deferred.UpdateDeferred(obs).ok());
    DenseUpdate(obs, mu, p);
    EXPECT_FALSE(deferred.settled());
    EXPECT_EQ(deferred.Mean(), whole.Mean());
    EXPECT_NEAR(deferred.Trace(), p.trace(), 1e-10 * p.trace());
  }
  const GpMap copy = deferred.Clone();
  deferred.Settle();
  EXPECT_TRUE(deferred.settled());
  EXPECT_EQ(deferred.Covariance(), whole.Covariance());
  EXPECT_EQ(deferred.Trace(), whole.Trace());
  EXPECT_FALSE(copy.settled());
  GpMap settled_copy = copy.Clone();
  settled_copy.Settle();
  EXPECT_EQ(settled_copy.Covariance(), whole.Covariance());
  // A bad update leaves even a pending map as it was.
  GpMap pending = base->Clone();
  ASSERT_TRUE(pending.UpdateDeferred(RandomObservations(rng, grid.num_cells(), 10)).ok());
  const double trace = pending.Trace();
  const std::vector<CellObservation> bad = {{.cell = -1, .value = 1.0, .variance = 0.1}};
  EXPECT_FALSE(pending.UpdateDeferred(bad).ok());
  EXPECT_EQ(pending.Trace(), trace);
}

// A clone shares the covariance until one of the two changes it: every way
// of changing it (an update, a deferred update settled, a shot that sees
// most of the field on OpenBLAS, near-certain zeros) leaves the other map
// bit for bit as it was, and gives bit for bit what a map of its own gives.
TEST(GpMapTest, ClonesShareTheCovarianceUntilOneChangesIt) {
  const FieldGrid grid = testing::CentredGrid(12, 10, 0.75);
  auto base = GpMap::Create(grid, GpParams::PaperPreset(0.75));
  ASSERT_TRUE(base.ok());
  const MatrixXd prior = base->Covariance();
  std::mt19937 rng(11);
  const std::vector<CellObservation> few = RandomObservations(rng, grid.num_cells(), 20);
  const std::vector<CellObservation> most = RandomObservations(rng, grid.num_cells(), 200);
  std::vector<DenseBackend> backends = {DenseBackend()};
  if (absl::StatusOr<DenseBackend> blas = DenseBackend::OpenBlas(); blas.ok()) {
    backends.push_back(*blas);
  }
  for (const DenseBackend& backend : backends) {
    SCOPED_TRACE(backend.name());
    using Change = std::function<absl::Status(GpMap&)>;
    const std::vector<std::pair<std::string, Change>> changes = {
        {"update", [&](GpMap& m) { return m.Update(few); }},
        {"deferred, settled",
         [&](GpMap& m) {
           absl::Status s = m.UpdateDeferred(few);
           m.Settle();
           return s;
         }},
        {"most cells", [&](GpMap& m) { return m.Update(most); }},
        {"zeros",
         [&](GpMap& m) {
           return m.FuseNearCertainZeros(std::vector<int>{3, 4, 50});
         }},
    };
    for (const auto& [name, change] : changes) {
      SCOPED_TRACE(name);
      GpMap original = base->Clone();
      original.set_dense_backend(backend);
      GpMap clone = original.Clone();
      EXPECT_TRUE(clone.shares_covariance());
      GpMap own = original.Clone();
      own.Unshare();
      EXPECT_FALSE(own.shares_covariance());
      ASSERT_TRUE(change(clone).ok());
      ASSERT_TRUE(change(own).ok());
      EXPECT_FALSE(clone.shares_covariance());
      EXPECT_EQ(original.Covariance(), prior);
      EXPECT_EQ(clone.Covariance(), own.Covariance());
      EXPECT_EQ(clone.Mean(), own.Mean());
      EXPECT_LT(clone.Trace(), original.Trace());
      // Changed again, the clone's own matrix is changed in place.
      ASSERT_TRUE(clone.Update(few).ok());
      ASSERT_TRUE(own.Update(few).ok());
      EXPECT_EQ(clone.Covariance(), own.Covariance());
      EXPECT_EQ(original.Covariance(), prior);
    }
  }
}
TEST(MergeObservationsTest, PrecisionsAddAndValuesArePrecisionWeighted) {
  const std::vector<CellObservation> obs = {{.cell = 3, .value = 1.0, .variance = 0.5},
                                            {.cell = 1, .value = 0.2, .variance = 0.3},
                                            {.cell = 3, .value = 0.0, .variance = 0.25}};
  auto merged = MergeObservations(obs, 5);
  ASSERT_TRUE(merged.ok());
  ASSERT_EQ(merged->size(), 2u);
  EXPECT_EQ((*merged)[0].cell, 1);
  EXPECT_EQ((*merged)[0].value, 0.2);
  EXPECT_EQ((*merged)[0].variance, 0.3);
  EXPECT_EQ((*merged)[1].cell, 3);
  EXPECT_DOUBLE_EQ((*merged)[1].variance, 1.0 / (2.0 + 4.0));
  EXPECT_DOUBLE_EQ((*merged)[1].value, (1.0 * 2.0 + 0.0 * 4.0) / 6.0);
}

TEST(GpMapTest, StaysSymmetricAndPsdOverManyRandomUpdates) {
  const FieldGrid grid = testing::CentredGrid(20, 20, 0.75);
  auto map = GpMap::Create(grid, GpParams::PaperPreset(0.75));
  ASSERT_TRUE(map.ok());
  // A building first, as a mission would, then 300 footprint-like updates.
  ASSERT_TRUE(map->FuseNearCertainZeros(grid.CellsInRectangle(Vec2(0, 0), Vec2(4, 7))).ok());
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> pos(-8, 8), size(0.5, 9), log_var(std::log(1e-4), 0.0);
  for (int i = 0; i < 300; ++i) {
    // Braced lists fix the order in which the generator is drawn.
    const Vec2 centre{pos(rng), pos(rng)};
    const Vec2 extent{size(rng), size(rng)};
    const std::vector<int> cells = grid.CellsInRectangle(centre, extent, /*yaw_rad=*/pos(rng));
    std::vector<CellObservation> obs;
    const double var = std::exp(log_var(rng));
    for (int c : cells)
      obs.push_back({.cell = c, .value = static_cast<double>(rng() % 2), .variance = var});
    ASSERT_TRUE(map->Update(obs).ok()) << "update " << i;
    ASSERT_TRUE(map->Covariance() == map->Covariance().transpose()) << "update " << i;
  }
  Eigen::SelfAdjointEigenSolver<MatrixXd> eig(map->Covariance(), Eigen::EigenvaluesOnly);
  EXPECT_GE(eig.eigenvalues().minCoeff(), -1e-9);
  EXPECT_TRUE(AllFinite(map->Mean()));
}

TEST(GpMapTest, NearCertainZerosPinTheCells) {
  const FieldGrid grid = testing::CentredGrid(16, 16, 0.75);
  auto map = GpMap::Create(grid, GpParams::PaperPreset(0.75));
  ASSERT_TRUE(map.ok());
  const std::vector<int> building = grid.CellsInRectangle(Vec2(1, -1), Vec2(3, 7.5));
  ASSERT_GT(building.size(), 30u);
  ASSERT_TRUE(map->FuseNearCertainZeros(building).ok());
  for (int c : building) {
    EXPECT_LE(map->Variance(c), GpMap::kNearCertainVariance);
    EXPECT_GT(map->Variance(c), 0.0);
    EXPECT_NEAR(map->Mean()[c], 0.0, 1e-5);
  }
  auto bad = map->FuseNearCertainZeros(std::vector<int>{0, 256});
  EXPECT_EQ(bad.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad.message(), HasSubstr("cells"));
}

TEST(GpMapTest, BadObservationsLeaveTheMapUntouched) {
  const FieldGrid grid = testing::CentredGrid(8, 8, 0.75);
  auto map = GpMap::Create(grid, GpParams::PaperPreset(0.75));
  ASSERT_TRUE(map.ok());
  const GpMap before = map->Clone();
  const CellObservation good{.cell = 5, .value = 1.0, .variance = 0.2};
  const struct {
    CellObservation bad;
    const char* field;
  } cases[] = {
      {{.cell = -1, .value = 1, .variance = 0.2}, "observations[1].cell"},
      {{.cell = 64, .value = 1, .variance = 0.2}, "observations[1].cell"},
      {{.cell = 3, .value = 1, .variance = 0.0}, "observations[1].variance"},
      {{.cell = 3, .value = 1, .variance = -0.5}, "observations[1].variance"},
      {{.cell = 3, .value = 1, .variance = NAN}, "observations[1].variance"},
      {{.cell = 3, .value = 1, .variance = INFINITY}, "observations[1].variance"},
      {{.cell = 3, .value = 1, .variance = 1e-320}, "observations[1].variance"},
      {{.cell = 3, .value = NAN, .variance = 0.2}, "observations[1].value"},
      {{.cell = 3, .value = -INFINITY, .variance = 0.2}, "observations[1].value"},
  };
  for (const auto& c : cases) {
    const std::vector<CellObservation> obs = {good, c.bad, good};
    const absl::Status status = map->Update(obs);
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << c.field;
    EXPECT_THAT(status.message(), HasSubstr(c.field));
    ASSERT_TRUE(map->Mean() == before.Mean()) << c.field;
    ASSERT_TRUE(map->Covariance() == before.Covariance()) << c.field;
  }
  // Merging that overflows is refused too.
  const std::vector<CellObservation> huge = {{.cell = 1, .value = 1e300, .variance = 1e-10},
                                             {.cell = 1, .value = 1e300, .variance = 1e-10}};
  EXPECT_EQ(map->Update(huge).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(map->Covariance() == before.Covariance());
  // Planning helpers ignore values but validate the rest.
  MatrixXd p = before.Covariance();
  const std::vector<CellObservation> nan_value = {{.cell = 1, .value = NAN, .variance = 0.2}};
  EXPECT_TRUE(UpdateCovariance(nan_value, p).ok());
  const std::vector<CellObservation> bad_cell = {{.cell = 99, .value = 0, .variance = 0.2}};
  EXPECT_EQ(TraceAfterUpdate(p, bad_cell).status().code(), absl::StatusCode::kInvalidArgument);
  MatrixXd not_square(3, 2);
  EXPECT_THAT(UpdateCovariance(nan_value, not_square).message(), HasSubstr("covariance"));
  // An empty update is a no-op.
  EXPECT_TRUE(map->Update({}).ok());
  EXPECT_TRUE(map->Covariance() == before.Covariance());
}

TEST(GpMapTest, FromPriorValidates) {
  const FieldGrid grid = testing::CentredGrid(2, 2, 1.0);
  EXPECT_THAT(
      GpMap::FromPrior(grid, VectorXd::Zero(3), MatrixXd::Identity(4, 4)).status().message(),
      HasSubstr("mean"));
  EXPECT_THAT(
      GpMap::FromPrior(grid, VectorXd::Zero(4), MatrixXd::Identity(3, 3)).status().message(),
      HasSubstr("covariance"));
  MatrixXd asym = MatrixXd::Identity(4, 4);
  asym(0, 1) = 0.5;
  EXPECT_THAT(GpMap::FromPrior(grid, VectorXd::Zero(4), asym).status().message(),
              HasSubstr("symmetric"));
  EXPECT_EQ(GpMap::Create(grid, {.length_scale_m = -1}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// A field past the dense map's size is refused before its n^2 covariance
// is allocated (a grid of that size is valid: the sparse map takes it).
TEST(GpMapTest, AFieldTooLargeForTheDenseMapIsRefused) {
  const FieldGrid grid = testing::CentredGrid(101, 100, 1.0);
  const absl::StatusOr<GpMap> map = GpMap::Create(grid, GpParams::PaperPreset(1.0));
  EXPECT_EQ(map.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(map.status().message(), HasSubstr("at most 10000 cells"));
  EXPECT_EQ(GpMap::FromPrior(grid, VectorXd(), MatrixXd()).status().code(),
            absl::StatusCode::kResourceExhausted);
}

}  // namespace
}  // namespace oaipp
