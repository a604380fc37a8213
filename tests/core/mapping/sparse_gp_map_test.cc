// The large-field map (core/mapping/sparse_gp_map.h) against computations
// made here: the prior's spectral fit against the dense published prior and
// a sparse solve of its own lattice, the sparse inference against a dense
// Kalman filter on the same prior (to 1e-9), and the prior's distance from
// the mission's Matérn 3/2 prior (docs/method.md §3.9).
#include "core/mapping/sparse_gp_map.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <tuple>
#include <vector>

#include "Eigen/Cholesky"
#include "Eigen/SparseCholesky"
#include "absl/strings/str_cat.h"
#include "core/mapping/camera.h"
#include "core/mapping/gmrf_prior.h"
#include "core/mapping/gp_map.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/mapping/centred_grid.h"
#include "tests/core/mapping/gmrf_reference.h"

namespace oaipp {
namespace {

using testing::DenseFieldCovariance;

using Eigen::MatrixXd;
using Eigen::VectorXd;
using ::testing::HasSubstr;

// Footprints of a downward camera at random places and heights, the
// paper's noise model; some cells repeated.
std::vector<std::vector<CellObservation>> RandomShots(const FieldGrid& grid, int shots,
                                                      std::uint32_t seed) {
  std::mt19937 rng(seed);
  const Vec2 lo = grid.min_W(), hi = grid.max_W();
  std::uniform_real_distribution<double> x(lo.x(), hi.x()), y(lo.y(), hi.y()), h(3.0, 20.0),
      label(0.0, 1.0);
  const DownwardCamera camera;
  const SensorNoise noise;
  std::vector<std::vector<CellObservation>> out;
  for (int s = 0; s < shots; ++s) {
    const Vec3 p(x(rng), y(rng), h(rng));
    std::vector<CellObservation> obs;
    for (int cell : camera.FootprintCells(grid, p)) {
      obs.push_back(
          {.cell = cell, .value = label(rng) < 0.2 ? 1.0 : 0.0, .variance = noise.Variance(p.z())});
    }
    if (!obs.empty()) obs.push_back(obs.front());
    out.push_back(std::move(obs));
  }
  return out;
}

double MaxRelative(const VectorXd& a, const VectorXd& b) {
  return ((a - b).array().abs() / b.array().abs().max(1e-300)).maxCoeff();
}

// The largest difference against the largest entry of b: for a vector whose
// entries may be near zero (a mean after near-certain zeros), whose rounding
// error is absolute at the scale of its largest entries, not relative to
// each one.
double MaxRelativeToScale(const VectorXd& a, const VectorXd& b) {
  return (a - b).lpNorm<Eigen::Infinity>() / std::max(b.lpNorm<Eigen::Infinity>(), 1e-300);
}

// The centre column of the inverse of the fitted field's precision on a
// side x side lattice, built here from the fit's parameters (not by
// MakeGmrfPrior), K^3 / s + (d + diagonal) I with K = a I + G, solved with
// Eigen's sparse LDL^T.
VectorXd LatticeCentreColumn(const GmrfFit& fit, int side, double diagonal) {
  const int n = side * side, centre = (side / 2) * side + side / 2;
  std::vector<Eigen::Triplet<double>> entries;
  for (int r = 0; r < side; ++r) {
    for (int c = 0; c < side; ++c) {
      const int s = r * side + c;
      int degree = 0;
      for (const auto& [dr, dc] : {std::pair{-1, 0}, {1, 0}, {0, -1}, {0, 1}}) {
        const int rr = r + dr, cc = c + dc;
        if (rr < 0 || rr >= side || cc < 0 || cc >= side) continue;
        entries.emplace_back(s, rr * side + cc, -1.0);
        ++degree;
      }
      entries.emplace_back(s, s, fit.a + degree);
    }
  }
  Eigen::SparseMatrix<double> k(n, n), identity(n, n);
  k.setFromTriplets(entries.begin(), entries.end());
  identity.setIdentity();
  const Eigen::SparseMatrix<double> k2 = k * k;
  const Eigen::SparseMatrix<double> q = (1.0 / fit.scale) * Eigen::SparseMatrix<double>(k2 * k) +
                                        identity * (fit.long_wavelength + diagonal);
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(q);
  EXPECT_EQ(ldlt.info(), Eigen::Success);
  VectorXd e = VectorXd::Zero(n);
  e[centre] = 1.0;
  return ldlt.solve(e);
}

// The fit's spectral sums against dense computations: the dense P0's
// interior variance against the centre of a dense published prior on a
// 41 x 41 field, the fitted one against a solve with the GMRF's
// precision on a 41 x 41 lattice; and the fit makes the two equal.
TEST(GmrfPriorTest, FitAgreesWithDenseComputations) {
  for (const double h : {0.75, 2.0}) {
    SCOPED_TRACE(absl::StrCat("resolution ", h));
    const GpParams params = GpParams::PaperPreset(h);
    const GmrfFit fit = FitGmrfToPublishedPrior(params, h);
    EXPECT_NEAR(fit.fitted_p0_variance, fit.dense_p0_variance, 1e-9 * fit.dense_p0_variance);

    const int side = 41, centre = (side / 2) * side + side / 2;
    absl::StatusOr<MatrixXd> p0 = PriorCovariance(testing::CentredGrid(side, side, h), params);
    ASSERT_TRUE(p0.ok());
    EXPECT_NEAR((*p0)(centre, centre), fit.dense_p0_variance, 1e-5 * fit.dense_p0_variance);

    const double lattice = LatticeCentreColumn(fit, side, 1.0 / params.noise_var)[centre];
    EXPECT_NEAR(fit.fitted_p0_variance, lattice, 1e-6 * lattice);
    RecordProperty(absl::StrCat("worst_lag_difference_at_", h),
                   absl::StrCat(fit.worst_lag_difference));
    EXPECT_LT(fit.worst_lag_difference, 0.05 * fit.dense_p0_variance);
  }
}

// The range the lattice's margin is counted in, 4 / kappa: the fitted
// field's correlation (the SPDE and its long-wavelength term, without the
// noise term), measured along a row of an 81 x 81 lattice from its centre
// by a sparse solve, is about 0.05 at the margin (ceil(4 / kappa) cells),
// against about 0.14 for the SPDE alone, and no larger from there to
// three margins, its slower oscillating tail included (gmrf_prior.h).
TEST(GmrfPriorTest, TheRangeIsWhereTheCorrelationIsSmall) {
  const GmrfFit fit = FitGmrfToPublishedPrior(GpParams::PaperPreset(1.0), 1.0);
  ASSERT_GT(fit.long_wavelength, 0.0);
  const int side = 81, centre = (side / 2) * side + side / 2;
  const VectorXd column = LatticeCentreColumn(fit, side, /*diagonal=*/0.0);
  const int range = static_cast<int>(std::ceil(fit.range_cells()));
  double beyond = 0.0;  // the largest |correlation| from one range to 3
  for (int lag = range; lag <= 3 * range && lag <= side / 2; ++lag) {
    beyond = std::max(beyond, std::abs(column[centre + lag] / column[centre]));
  }
  const double at_range = column[centre + range] / column[centre];
  RecordProperty("correlation_at_range", absl::StrCat(at_range));
  RecordProperty("largest_beyond", absl::StrCat(beyond));
  std::printf("range %d cells: correlation %.3f there, at most %.3f beyond\n", range, at_range,
              beyond);
  EXPECT_GT(at_range, 0.0);
  EXPECT_LT(at_range, 0.06);
  EXPECT_LE(beyond, at_range);
}

// At the field's edges the published prior's variance is higher than
// inside (its noise term reduces less where a cell has fewer neighbours:
// here 40 % at an edge, twice at a corner). The variance match
// (gmrf_prior.h) gives every cell of the sparse prior the dense prior's
// variance: to rounding on a field no wider than the match's reference
// field, and to 1e-5 of it on ones wider in one direction (48 x 12 and 32 x
// 8, the reference 31 wide; at 32 one column takes the reference's
// middle), where the cells farther than the band from the ends take the
// reference's middle (docs/method.md §3.9), and on a single row. The covariances
// are solved by Eigen's sparse Cholesky, the dense prior computed whole.
TEST(GmrfPriorTest, EveryCellHasTheDensePriorsVariance) {
  const GpParams params = GpParams::PaperPreset(1.0);
  ASSERT_EQ(VarianceMatchBand(params, 1.0), 15);
  for (const auto& [nx, ny, bound] :
       {std::tuple{24, 24, 1e-9}, {48, 12, 1e-5}, {32, 8, 1e-5}, {1, 1, 1e-9}, {40, 1, 1e-5}}) {
    SCOPED_TRACE(absl::StrCat(nx, " x ", ny));
    const FieldGrid grid = testing::CentredGrid(nx, ny, 1.0);
    absl::StatusOr<GmrfPrior> prior = MakeGmrfPrior(grid, params);
    ASSERT_TRUE(prior.ok()) << prior.status();
    absl::StatusOr<MatrixXd> dense = PriorCovariance(grid, params);
    ASSERT_TRUE(dense.ok());
    const VectorXd dense_var = dense->diagonal();
    const VectorXd var = DenseFieldCovariance(*prior).diagonal();
    EXPECT_LT(MaxRelative(var, dense_var), bound);
    if (nx >= 8 && ny >= 8) {
      EXPECT_GT(dense_var[0], 1.9 * dense_var[grid.Index(ny / 2, nx / 2)]);
    }
  }
}

// The inference is exact for its prior: after each batch of shots (with
// repeated cells and the ground under a building fused as near-certain
// zeros), the mean (to 1e-9 of its largest entry) and every variance (to
// 1e-9 relative) equal a dense Kalman filter's on the same prior.
TEST(SparseGpMapTest, EqualsADenseKalmanFilterOnTheSamePrior) {
  const FieldGrid grid = testing::CentredGrid(14, 12, 1.0);
  const GpParams params = GpParams::PaperPreset(1.0);
  absl::StatusOr<GmrfPrior> prior = MakeGmrfPrior(grid, params);
  ASSERT_TRUE(prior.ok()) << prior.status();
  absl::StatusOr<GpMap> dense = GpMap::FromPrior(
      grid, VectorXd::Constant(grid.num_cells(), params.prior_mean), DenseFieldCovariance(*prior));
  ASSERT_TRUE(dense.ok()) << dense.status();
  absl::StatusOr<SparseGpMap> sparse = SparseGpMap::FromPrior(grid, *prior);
  ASSERT_TRUE(sparse.ok()) << sparse.status();

  auto expect_equal = [&](const std::string& when) {
    absl::StatusOr<VectorXd> var = sparse->Variances();
    ASSERT_TRUE(var.ok()) << var.status();
    EXPECT_LT(MaxRelativeToScale(*sparse->Mean(), dense->Mean()), 1e-9) << when;
    EXPECT_LT(MaxRelative(*var, dense->Variances()), 1e-9) << when;
    absl::StatusOr<double> trace = sparse->Trace();
    ASSERT_TRUE(trace.ok());
    EXPECT_NEAR(*trace, dense->Trace(), 1e-9 * dense->Trace()) << when;
  };
  expect_equal("at the prior");
  const std::vector<int> building = {grid.Index(3, 3), grid.Index(3, 4), grid.Index(4, 3),
                                     grid.Index(4, 4), grid.Index(4, 4)};
  ASSERT_TRUE(dense->FuseNearCertainZeros(building).ok());
  ASSERT_TRUE(sparse->FuseNearCertainZeros(building).ok());
  expect_equal("after the building");
  int batch = 0;
  for (const std::vector<CellObservation>& shot : RandomShots(grid, 6, 7)) {
    ASSERT_TRUE(dense->Update(shot).ok());
    ASSERT_TRUE(sparse->Update(shot).ok());
    expect_equal("after shot " + std::to_string(batch++));
  }
}

// Fusion is additive: the same shots in another order and split otherwise
// give the same map (to rounding), and a map restored from the two vectors
// a snapshot holds is the same map.
TEST(SparseGpMapTest, AnyOrderAndARestoreGiveTheSameMap) {
  const FieldGrid grid = testing::CentredGrid(20, 16, 1.0);
  const GpParams params = GpParams::PaperPreset(1.0);
  const auto shots = RandomShots(grid, 8, 11);
  absl::StatusOr<SparseGpMap> forward = SparseGpMap::Create(grid, params);
  absl::StatusOr<SparseGpMap> backward = SparseGpMap::Create(grid, params);
  ASSERT_TRUE(forward.ok() && backward.ok());
  for (const auto& shot : shots) ASSERT_TRUE(forward->Update(shot).ok());
  std::vector<CellObservation> all;
  for (auto it = shots.rbegin(); it != shots.rend(); ++it) {
    all.insert(all.end(), it->rbegin(), it->rend());
  }
  ASSERT_TRUE(backward->Update(all).ok());
  EXPECT_LT(MaxRelative(*backward->Mean(), *forward->Mean()), 1e-12);
  EXPECT_LT(MaxRelative(*backward->Variances(), *forward->Variances()), 1e-12);

  absl::StatusOr<SparseGpMap> restored = SparseGpMap::Create(grid, params);
  ASSERT_TRUE(restored.ok());
  ASSERT_TRUE(restored->Restore(forward->AddedPrecision(), forward->AddedInformation()).ok());
  EXPECT_LT(MaxRelative(*restored->Mean(), *forward->Mean()), 1e-12);
  EXPECT_LT(MaxRelative(*restored->Variances(), *forward->Variances()), 1e-12);
}

// The site's prior cache (GmrfPriorCache) hands out MakeGmrfPrior's prior
// bit for bit, once per shape and parameters whatever the field's origin;
// a map made from it that factorises on its first read equals one that
// factorised at once, after the same shots.
TEST(GmrfPriorCacheTest, SharesThePriorPerShapeAndAMapFromItIsTheSame) {
  const FieldGrid grid = testing::CentredGrid(20, 16, 1.0);
  const GpParams params = GpParams::PaperPreset(1.0);
  GmrfPriorCache cache;
  absl::StatusOr<std::shared_ptr<const GmrfPrior>> first = cache.Get(grid, params);
  ASSERT_TRUE(first.ok()) << first.status();
  absl::StatusOr<GmrfPrior> direct = MakeGmrfPrior(grid, params);
  ASSERT_TRUE(direct.ok());
  EXPECT_EQ(Eigen::SparseMatrix<double>((*first)->precision - direct->precision).norm(), 0.0);
  EXPECT_TRUE((*first)->information == direct->information);
  EXPECT_EQ((*first)->field_state, direct->field_state);
  // The same shape elsewhere: the same prior, not computed again.
  auto moved = FieldGrid::Create(Vec2(100.0, -40.0), 20, 16, 1.0);
  ASSERT_TRUE(moved.ok());
  absl::StatusOr<std::shared_ptr<const GmrfPrior>> again = cache.Get(*moved, params);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->get(), first->get());
  EXPECT_EQ(cache.computations(), 1);
  // Another prior mean is another prior (its information differs).
  GpParams other = params;
  other.prior_mean = 0.2;
  ASSERT_TRUE(cache.Get(grid, other).ok());
  EXPECT_EQ(cache.computations(), 2);
  // Bad parameters: MakeGmrfPrior's error, not remembered.
  GpParams bad = params;
  bad.length_scale_m = -1.0;
  EXPECT_EQ(cache.Get(grid, bad).status().code(), absl::StatusCode::kInvalidArgument);

  const auto shots = RandomShots(grid, 6, 5);
  absl::StatusOr<SparseGpMap> now = SparseGpMap::FromPrior(grid, **first);
  absl::StatusOr<SparseGpMap> later =
      SparseGpMap::FromPrior(grid, **first, SparseGpMap::Factorise::kWhenRead);
  ASSERT_TRUE(now.ok() && later.ok());
  EXPECT_EQ(later->factor_nonzeros(), 0);  // nothing factorised yet
  for (const auto& shot : shots) {
    ASSERT_TRUE(now->Update(shot).ok());
    ASSERT_TRUE(later->Update(shot).ok());
  }
  EXPECT_TRUE(*later->Mean() == *now->Mean());
  EXPECT_TRUE(*later->Variances() == *now->Variances());
}

// A bad observation names its entry and field and changes nothing; a
// snapshot of another size or with a negative precision is refused.
TEST(SparseGpMapTest, BadInputIsRefusedAndChangesNothing) {
  const FieldGrid grid = testing::CentredGrid(10, 10, 1.0);
  absl::StatusOr<SparseGpMap> map = SparseGpMap::Create(grid, GpParams::PaperPreset(1.0));
  ASSERT_TRUE(map.ok());
  const VectorXd mean = *map->Mean();
  const std::vector<CellObservation> bad = {{.cell = 3, .value = 1.0, .variance = 0.4},
                                            {.cell = 100, .value = 1.0, .variance = 0.4}};
  const absl::Status status = map->Update(bad);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(status.message(), HasSubstr("observations[1].cell"));
  const std::vector<CellObservation> negative = {{.cell = 3, .value = 1.0, .variance = -1.0}};
  EXPECT_THAT(map->Update(negative).message(), HasSubstr("observations[0].variance"));
  EXPECT_EQ(*map->Mean(), mean);
  EXPECT_EQ(map->AddedPrecision(), VectorXd::Zero(100));
  EXPECT_EQ(map->Restore(VectorXd::Zero(99), VectorXd::Zero(99)).code(),
            absl::StatusCode::kInvalidArgument);
  VectorXd minus = VectorXd::Zero(100);
  minus[5] = -1.0;
  EXPECT_EQ(map->Restore(minus, VectorXd::Zero(100)).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(*map->Mean(), mean);
  EXPECT_EQ(
      MakeGmrfPrior(grid, GpParams::PaperPreset(1.0), {.margin_ranges = -1.0}).status().code(),
      absl::StatusCode::kInvalidArgument);
}

// How far the sparse prior is from the mission's Matérn 3/2 prior (the
// dense map's), on E1's field (40 x 40 cells at 0.75 m) before and after 25
// shots: the figures docs/method.md §3.9 quotes (every cell's prior
// variance to 1e-9 of the prior's; after the shots the worst cell 0.0095 of
// it, the trace +0.16 %). The prior is held to 1e-6 (rounding aside, what
// the match gives wherever the reference is free of edges), the posterior's
// worst cell to 0.013 (0.0120 on 80 x 80) and its trace to the 0.3 % the
// docs state, within the 0.5 % the large-field map is held to.
// OAIPP_FIDELITY_SIDE=80 runs it on 80 x 80 cells (6,400; 40 s, 0.7 GB).
TEST(SparseGpMapTest, StaysCloseToTheMatern32Map) {
  const char* side_env = std::getenv("OAIPP_FIDELITY_SIDE");
  const int side = side_env != nullptr ? std::atoi(side_env) : 40;
  ASSERT_GE(side, 8);
  const FieldGrid grid = testing::CentredGrid(side, side, 0.75);
  const GpParams params = GpParams::PaperPreset(0.75);
  absl::StatusOr<GpMap> dense = GpMap::Create(grid, params);
  absl::StatusOr<SparseGpMap> sparse = SparseGpMap::Create(grid, params);
  ASSERT_TRUE(dense.ok() && sparse.ok());
  const double prior_var = dense->Variances().maxCoeff();
  auto compare = [&](const std::string& when, double var_bound, double trace_bound) {
    const VectorXd var = *sparse->Variances();
    std::vector<double> off(static_cast<std::size_t>(grid.num_cells()));
    VectorXd::Map(off.data(), grid.num_cells()) = (var - dense->Variances()).cwiseAbs() / prior_var;
    const auto middle = off.begin() + static_cast<std::ptrdiff_t>(off.size() / 2);
    std::nth_element(off.begin(), middle, off.end());
    const double median = *middle;
    const double worst = *std::max_element(middle, off.end());
    const double trace = var.sum() / dense->Trace() - 1.0;
    const double mean_rmse =
        std::sqrt((*sparse->Mean() - dense->Mean()).squaredNorm() / grid.num_cells());
    RecordProperty(when + "_worst_variance_over_prior", absl::StrCat(worst));
    RecordProperty(when + "_trace_relative", absl::StrCat(trace));
    RecordProperty(when + "_mean_rmse", absl::StrCat(mean_rmse));
    std::printf(
        "%s: variance difference of the prior's: worst %.2e, median %.2e; trace %+.2e, mean RMSE "
        "%.4f\n",
        when.c_str(), worst, median, trace, mean_rmse);
    EXPECT_LT(worst, var_bound) << when;
    EXPECT_LT(std::abs(trace), trace_bound) << when;
  };
  // Every cell's variance is the dense prior's (the variance match).
  compare("prior", 1e-6, 1e-6);
  for (const auto& shot : RandomShots(grid, 25, 5)) {
    ASSERT_TRUE(dense->Update(shot).ok());
    ASSERT_TRUE(sparse->Update(shot).ok());
  }
  compare("posterior", 0.013, 0.003);
}

}  // namespace
}  // namespace oaipp
