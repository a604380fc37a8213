// The planner's window onto a large map (core/mapping/field_window.h)
// against the exact posterior covariance, computed here as columns of Q^-1
// by Eigen's own sparse LDL^T of the map's whole precision (not CHOLMOD,
// not the window's Schur complement): exact when the margin covers the
// lattice, and the error of the default margin measured on a field wider
// than the window.
#include "core/mapping/field_window.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "Eigen/Cholesky"
#include "Eigen/SparseCholesky"
#include "core/mapping/camera.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/mapping/centred_grid.h"

namespace oaipp {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using ::testing::HasSubstr;

// The exact posterior covariance between the given field cells.
MatrixXd ExactCovariance(const SparseGpMap& map, const std::vector<int>& cells) {
  const Eigen::SparseMatrix<double> q = map.precision().selfadjointView<Eigen::Lower>();
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(q);
  EXPECT_EQ(ldlt.info(), Eigen::Success);
  const int n = static_cast<int>(cells.size());
  MatrixXd columns = MatrixXd::Zero(q.rows(), n);
  for (int j = 0; j < n; ++j) columns(map.prior().field_state[cells[j]], j) = 1.0;
  columns = ldlt.solve(columns);
  MatrixXd out(n, n);
  for (int i = 0; i < n; ++i) out.row(i) = columns.row(map.prior().field_state[cells[i]]);
  return 0.5 * (out + out.transpose());
}

// Camera footprints at random places and heights with the paper's noise,
// fused into `map`.
void FuseRandomShots(SparseGpMap& map, int shots, std::uint32_t seed) {
  std::mt19937 rng(seed);
  const FieldGrid& grid = map.grid();
  std::uniform_real_distribution<double> x(grid.min_W().x(), grid.max_W().x()),
      y(grid.min_W().y(), grid.max_W().y()), h(3.0, 15.0), label(0.0, 1.0);
  const DownwardCamera camera;
  const SensorNoise noise;
  for (int s = 0; s < shots; ++s) {
    const Vec3 p(x(rng), y(rng), h(rng));
    std::vector<CellObservation> obs;
    for (int cell : camera.FootprintCells(grid, p)) {
      obs.push_back({.cell = cell, .value = label(rng), .variance = noise.Variance(p.z())});
    }
    ASSERT_TRUE(map.Update(obs).ok());
  }
}

// The largest difference of a covariance entry, relative to the largest
// prior variance (the scale the fidelity bar uses).
double WorstDifference(const MatrixXd& a, const MatrixXd& b, double scale) {
  return (a - b).cwiseAbs().maxCoeff() / scale;
}

TEST(WindowAroundTest, ClipsToTheFieldAndKeepsCellsAligned) {
  const FieldGrid field = testing::CentredGrid(50, 40, 1.0);  // [-25, 25] x [-20, 20]
  auto inside = WindowAround(field, Vec2(0.3, -0.2), 5.0);
  ASSERT_TRUE(inside.ok()) << inside.status();
  // Overlapping [-4.7, 5.3] x [-5.2, 4.8]: columns 20..30, rows 14..24.
  EXPECT_EQ(inside->first_col, 20);
  EXPECT_EQ(inside->first_row, 14);
  EXPECT_EQ(inside->grid.nx(), 11);
  EXPECT_EQ(inside->grid.ny(), 11);
  for (int k : {0, 17, 120}) {
    const Vec2 a = inside->grid.CellCentreXY(k);
    const Vec2 b = field.CellCentreXY(inside->field_cells[k]);
    EXPECT_NEAR((a - b).norm(), 0.0, 1e-12);
  }
  // A centre beyond a corner gives the corner's cells.
  auto corner = WindowAround(field, Vec2(100.0, -100.0), 3.0);
  ASSERT_TRUE(corner.ok());
  EXPECT_EQ(corner->first_col + corner->grid.nx(), 50);
  EXPECT_EQ(corner->first_row, 0);
  EXPECT_EQ(corner->grid.nx(), 3);
  EXPECT_EQ(corner->grid.ny(), 3);
  // The whole field.
  auto all = WindowAround(field, Vec2::Zero(), 1000.0);
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(all->grid.num_cells(), field.num_cells());

  EXPECT_THAT(WindowAround(field, Vec2(NAN, 0), 5.0).status().message(), HasSubstr("centre_W"));
  EXPECT_THAT(WindowAround(field, Vec2::Zero(), 0.0).status().message(), HasSubstr("half_width_m"));
  EXPECT_THAT(WindowAround(field, Vec2::Zero(), INFINITY).status().message(),
              HasSubstr("half_width_m"));
}

TEST(WindowMapTest, IsExactWhenTheMarginCoversTheLattice) {
  auto map = SparseGpMap::Create(testing::CentredGrid(24, 20, 1.0), GpParams::PaperPreset(1.0));
  ASSERT_TRUE(map.ok()) << map.status();
  FuseRandomShots(*map, 6, 3);
  ASSERT_TRUE(map->FuseNearCertainZeros(std::vector<int>{5, 6, 29, 30}).ok());
  auto window = WindowAround(map->grid(), Vec2(-6.0, 2.0), 4.0);
  ASSERT_TRUE(window.ok());
  auto local = WindowMap(*map, *window, {.margin_ranges = 100.0}, DenseBackend());
  ASSERT_TRUE(local.ok()) << local.status();

  const MatrixXd exact = ExactCovariance(*map, window->field_cells);
  const double scale = exact.diagonal().maxCoeff();
  EXPECT_LT(WorstDifference(local->Covariance(), exact, scale), 1e-9);
  auto mean = map->Mean();
  ASSERT_TRUE(mean.ok());
  for (int k = 0; k < local->num_cells(); ++k) {
    EXPECT_EQ(local->Mean()[k], (*mean)[window->field_cells[k]]);
  }
}

TEST(WindowMapTest, TheDefaultMarginIsAlmostExact) {
  // A field four times the window's width each way, shots all over it.
  auto map = SparseGpMap::Create(testing::CentredGrid(64, 64, 1.0), GpParams::PaperPreset(1.0));
  ASSERT_TRUE(map.ok()) << map.status();
  FuseRandomShots(*map, 40, 7);
  auto window = WindowAround(map->grid(), Vec2(3.0, -2.0), 8.0);
  ASSERT_TRUE(window.ok());
  const MatrixXd exact = ExactCovariance(*map, window->field_cells);
  auto prior = SparseGpMap::Create(map->grid(), GpParams::PaperPreset(1.0));
  ASSERT_TRUE(prior.ok());
  auto prior_variances = prior->Variances();
  ASSERT_TRUE(prior_variances.ok());
  const double scale = prior_variances->maxCoeff();

  // The error of each margin, and of the variance reduction a footprint in
  // the window's middle would bring (the planner's trace objective).
  const DownwardCamera camera;
  const std::vector<int> seen = camera.FootprintCells(window->grid, Vec3(3.0, -2.0, 8.0));
  ASSERT_FALSE(seen.empty());
  const double r = SensorNoise().Variance(8.0);
  const auto reduction = [&](const MatrixXd& p) {
    MatrixXd s(seen.size(), seen.size());
    MatrixXd cross(p.rows(), seen.size());
    for (std::size_t j = 0; j < seen.size(); ++j) {
      cross.col(static_cast<Eigen::Index>(j)) = p.col(seen[j]);
      for (std::size_t i = 0; i < seen.size(); ++i) s(i, j) = p(seen[i], seen[j]);
    }
    s.diagonal().array() += r;
    return (cross.transpose().array() * Eigen::LLT<MatrixXd>(s).solve(cross.transpose()).array())
        .sum();
  };
  const double exact_reduction = reduction(exact);
  double previous = INFINITY;
  for (double margin : {0.0, 1.0, 2.0, 3.0}) {
    auto local = WindowMap(*map, *window, {.margin_ranges = margin}, DenseBackend());
    ASSERT_TRUE(local.ok()) << local.status();
    const double error = WorstDifference(local->Covariance(), exact, scale);
    const double reduction_error = std::abs(reduction(local->Covariance()) / exact_reduction - 1);
    RecordProperty("margin_" + std::to_string(static_cast<int>(margin)) + "_worst",
                   std::to_string(error));
    std::printf(
        "margin %.0f ranges: worst covariance difference %.2e of the prior variance, "
        "a footprint's variance reduction off by %.2e\n",
        margin, error, reduction_error);
    EXPECT_LT(error, previous) << margin;
    previous = error;
    // Conditioning can only lower variances.
    EXPECT_TRUE(((exact.diagonal() - local->Covariance().diagonal()).array() > -1e-12).all());
    if (margin == FieldWindowOptions{}.margin_ranges) {
      EXPECT_LT(error, 1e-5);
      EXPECT_LT(reduction_error, 1e-5);
    }
  }
}

TEST(WindowMapTest, RefusesWhatIsNotAWindowOfTheMap) {
  auto map = SparseGpMap::Create(testing::CentredGrid(20, 20, 1.0), GpParams::PaperPreset(1.0));
  ASSERT_TRUE(map.ok());
  auto other = WindowAround(testing::CentredGrid(30, 30, 1.0), Vec2(12.0, 12.0), 3.0);
  ASSERT_TRUE(other.ok());
  EXPECT_EQ(WindowMap(*map, *other, {}, DenseBackend()).status().code(),
            absl::StatusCode::kInvalidArgument);
  auto window = WindowAround(map->grid(), Vec2::Zero(), 3.0);
  ASSERT_TRUE(window.ok());
  EXPECT_THAT(WindowMap(*map, *window, {.margin_ranges = -1.0}, DenseBackend()).status().message(),
              HasSubstr("options.margin_ranges"));
}

}  // namespace
}  // namespace oaipp
