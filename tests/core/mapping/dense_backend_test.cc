// OpenBLAS against Eigen for the Kalman update's rank-m product, and a map
// fused through each: the same numbers to round-off. A shot that sees most of
// the field takes another route on OpenBLAS (block by block): it is checked
// against the textbook update with an explicit observation matrix.
#include "core/mapping/dense_backend.h"

#include <random>
#include <span>
#include <thread>
#include <utility>
#include <vector>

#include "Eigen/Cholesky"

#include "core/mapping/camera.h"
#include "core/mapping/gp_map.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace oaipp {
namespace {

// deploy/install-deps.sh installs libopenblas-pthread-dev. Each test holds
// both backends as values: nothing in the process is switched.
class DenseBackendTest : public ::testing::Test {
 protected:
  void SetUp() override {
    absl::StatusOr<DenseBackend> loaded = DenseBackend::OpenBlas();
    ASSERT_TRUE(loaded.ok()) << loaded.status();
    blas_ = *loaded;
  }
  DenseBackend blas_;
  const DenseBackend eigen_;
};

TEST_F(DenseBackendTest, OpenBlasRankUpdateEqualsEigensOnTheLowerTriangle) {
  EXPECT_THAT(blas_.name(), ::testing::StartsWith("openblas ("));
  EXPECT_EQ(eigen_.name(), "eigen");
  EXPECT_TRUE(blas_.is_open_blas());
  EXPECT_FALSE(eigen_.is_open_blas());
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  for (const auto& [n, m] : {std::pair{7, 1}, std::pair{300, 41}, std::pair{1000, 260}}) {
    Eigen::MatrixXd b(n, m);
    for (double& v : b.reshaped()) v = normal(rng);
    Eigen::MatrixXd start(n, n);
    for (double& v : start.reshaped()) v = normal(rng);
    // The plain product, written out, as the reference for both.
    const Eigen::MatrixXd expected = start - 0.5 * b * b.transpose();
    Eigen::MatrixXd blas = start;
    blas_.SymmetricRankUpdate(-0.5, b, blas);
    Eigen::MatrixXd eigen = start;
    eigen_.SymmetricRankUpdate(-0.5, b, eigen);
    const double scale = 1.0 + m;
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        if (i >= j) {
          ASSERT_NEAR(blas(i, j), expected(i, j), 1e-12 * scale) << i << ", " << j;
          ASSERT_NEAR(eigen(i, j), expected(i, j), 1e-12 * scale) << i << ", " << j;
        } else {
          ASSERT_EQ(blas(i, j), start(i, j));  // the upper triangle is left alone
        }
      }
    }
  }
}

TEST_F(DenseBackendTest, OpenBlasTriangularSolveEqualsEigens) {
  std::mt19937 rng(4);
  std::normal_distribution<double> normal;
  for (const auto& [n, m] : {std::pair{5, 1}, std::pair{400, 90}}) {
    Eigen::MatrixXd a(m, m);
    for (double& v : a.reshaped()) v = normal(rng);
    Eigen::MatrixXd s = a * a.transpose() + m * Eigen::MatrixXd::Identity(m, m);
    // Garbage above the diagonal must be ignored.
    Eigen::MatrixXd lower = Eigen::LLT<Eigen::MatrixXd>(s).matrixLLT();
    lower.triangularView<Eigen::StrictlyUpper>().setConstant(1e300);
    Eigen::MatrixXd b(n, m);
    for (double& v : b.reshaped()) v = normal(rng);
    Eigen::MatrixXd blas = b;
    blas_.SolveRightLowerTransposed(lower, blas);
    Eigen::MatrixXd eigen = b;
    eigen_.SolveRightLowerTransposed(lower, eigen);
    // Both solve X L^T = B: check against B itself.
    const Eigen::MatrixXd l = lower.triangularView<Eigen::Lower>();
    EXPECT_LT((blas * l.transpose() - b).cwiseAbs().maxCoeff(), 1e-10);
    EXPECT_LT((eigen * l.transpose() - b).cwiseAbs().maxCoeff(), 1e-10);
    EXPECT_LT((blas - eigen).cwiseAbs().maxCoeff(), 1e-10);
  }
}

TEST_F(DenseBackendTest, OpenBlasCholeskyEqualsEigensAndRefusesWhatIsNotPositiveDefinite) {
  std::mt19937 rng(6);
  std::normal_distribution<double> normal;
  for (const int m : {1, 30, 300}) {
    Eigen::MatrixXd a(m, m);
    for (double& v : a.reshaped()) v = normal(rng);
    const Eigen::MatrixXd s = a * a.transpose() + Eigen::MatrixXd::Identity(m, m);
    Eigen::MatrixXd blas = s;
    ASSERT_TRUE(blas_.CholeskyLowerInPlace(blas));
    Eigen::MatrixXd eigen = s;
    ASSERT_TRUE(eigen_.CholeskyLowerInPlace(eigen));
    const Eigen::MatrixXd l_blas = blas.triangularView<Eigen::Lower>();
    const Eigen::MatrixXd l_eigen = eigen.triangularView<Eigen::Lower>();
    EXPECT_LT((l_blas * l_blas.transpose() - s).cwiseAbs().maxCoeff(), 1e-10 * m);
    EXPECT_LT((l_blas - l_eigen).cwiseAbs().maxCoeff(), 1e-10);
  }
  Eigen::MatrixXd indefinite{{1.0, 2.0}, {2.0, 1.0}};  // eigenvalues 3 and -1
  Eigen::MatrixXd copy = indefinite;
  EXPECT_FALSE(blas_.CholeskyLowerInPlace(copy));
  EXPECT_FALSE(eigen_.CholeskyLowerInPlace(indefinite));
}

// L^-1 on both backends: L times it is the identity, and garbage above the
// diagonal is ignored (only the lower triangle is written and read).
TEST_F(DenseBackendTest, TriangularInverseTimesTheFactorIsTheIdentityOnBothBackends) {
  std::mt19937 rng(8);
  std::normal_distribution<double> normal;
  for (const int m : {1, 40, 350}) {
    Eigen::MatrixXd a(m, m);
    for (double& v : a.reshaped()) v = normal(rng);
    const Eigen::MatrixXd s = a * a.transpose() + m * Eigen::MatrixXd::Identity(m, m);
    Eigen::MatrixXd lower = Eigen::LLT<Eigen::MatrixXd>(s).matrixLLT();
    lower.triangularView<Eigen::StrictlyUpper>().setConstant(1e300);
    const Eigen::MatrixXd l = lower.triangularView<Eigen::Lower>();
    for (const bool open_blas : {true, false}) {
      Eigen::MatrixXd inv = lower;
      (open_blas ? blas_ : eigen_).InverseLowerInPlace(inv);
      const Eigen::MatrixXd inv_lower = inv.triangularView<Eigen::Lower>();
      EXPECT_LT((l * inv_lower - Eigen::MatrixXd::Identity(m, m)).cwiseAbs().maxCoeff(), 1e-12)
          << "m " << m << (open_blas ? " on OpenBLAS" : " on Eigen");
    }
  }
}

TEST_F(DenseBackendTest, AMapFusedThroughOpenBlasMatchesEigenToRoundOff) {
  const FieldGrid grid = *FieldGrid::FromBounds(Vec2(-15, -15), Vec2(15, 15), 0.75);
  GpMap on_eigen = *GpMap::Create(grid, GpParams::PaperPreset(0.75));
  GpMap on_blas = on_eigen.Clone();
  // Two maps in one process, each on its own backend.
  on_blas.set_dense_backend(blas_);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> where(-12, 12), height(3, 20);
  for (int shot = 0; shot < 12; ++shot) {
    const Vec3 camera(where(rng), where(rng), height(rng));
    const std::vector<int> cells = DownwardCamera{}.VisibleFootprintCells(grid, camera, nullptr);
    std::vector<CellObservation> obs;
    for (int c : cells)
      obs.push_back({.cell = c, .value = (c % 7 == 0) ? 1.0 : 0.0, .variance = 0.3});
    ASSERT_TRUE(on_blas.Update(obs).ok());
    ASSERT_TRUE(on_eigen.Update(obs).ok());
  }
  EXPECT_NEAR(on_blas.Trace(), on_eigen.Trace(), 1e-10 * on_eigen.Trace());
  EXPECT_LT((on_blas.Mean() - on_eigen.Mean()).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_LT((on_blas.Covariance() - on_eigen.Covariance()).cwiseAbs().maxCoeff(), 1e-10);
  // Still exactly symmetric (the lower triangle is mirrored).
  EXPECT_EQ(on_blas.Covariance(), on_blas.Covariance().transpose());
}

// The textbook Kalman update, with one row of H per observation (repeated
// cells stay separate rows): K = P H^T (H P H^T + R)^-1, mu += K (z - H mu),
// P -= K H P.
void TextbookUpdate(std::span<const CellObservation> obs, Eigen::VectorXd& mean,
                    Eigen::MatrixXd& p) {
  const auto n = p.rows();
  const auto m = static_cast<Eigen::Index>(obs.size());
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(m, n);
  Eigen::VectorXd z(m);
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(m, m);
  for (Eigen::Index k = 0; k < m; ++k) {
    h(k, obs[k].cell) = 1.0;
    z[k] = obs[k].value;
    r(k, k) = obs[k].variance;
  }
  const Eigen::MatrixXd s = h * p * h.transpose() + r;
  const Eigen::MatrixXd gain = s.llt().solve(h * p).transpose();  // P H^T S^-1
  mean += gain * (z - h * mean);
  p -= gain * h * p;
}

TEST_F(DenseBackendTest, AShotSeeingMostOfTheFieldIsFusedAsTheTextbookUpdate) {
  const FieldGrid grid = *FieldGrid::FromBounds(Vec2(-7.5, -7.5), Vec2(7.5, 7.5), 0.75);
  GpMap on_blas = *GpMap::Create(grid, GpParams::PaperPreset(0.75));
  GpMap on_eigen = on_blas.Clone();
  on_blas.set_dense_backend(blas_);
  EXPECT_EQ(on_blas.Clone().dense_backend(), blas_);  // a copy keeps it
  Eigen::VectorXd mean = on_blas.Mean();
  Eigen::MatrixXd p = on_blas.Covariance();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> where(-3, 3), height(14, 26), label(0, 1);
  int all_seen = 0;
  for (int shot = 0; shot < 4; ++shot) {
    const Vec3 camera(where(rng), where(rng), height(rng));
    const std::vector<int> cells = DownwardCamera{}.VisibleFootprintCells(grid, camera, nullptr);
    // Most of the field, and at least once all of it (C empty).
    ASSERT_GE(2 * cells.size(), static_cast<std::size_t>(grid.num_cells())) << "shot " << shot;
    all_seen += cells.size() == static_cast<std::size_t>(grid.num_cells()) ? 1 : 0;
    std::vector<CellObservation> obs;
    for (int c : cells) obs.push_back({.cell = c, .value = label(rng), .variance = 0.3});
    // Some cells seen twice with another noise (their precisions add), and
    // some near certain (R small against P_JJ).
    for (std::size_t k = 0; k < cells.size(); k += 9) {
      obs.push_back({.cell = cells[k], .value = label(rng), .variance = 0.8});
    }
    for (std::size_t k = 4; k < cells.size(); k += 31) obs[k].variance = 1e-6;
    ASSERT_TRUE(on_blas.Update(obs).ok());
    ASSERT_TRUE(on_eigen.Update(obs).ok());
    TextbookUpdate(obs, mean, p);
    // Where R = 1e-6 the means are sensitive (cond(S) ~ 1e6): the three
    // routes differ there by about 1e-10, everywhere else by round-off.
    EXPECT_LT((on_blas.Mean() - mean).cwiseAbs().maxCoeff(), 1e-9) << "shot " << shot;
    EXPECT_LT((on_blas.Covariance() - p).cwiseAbs().maxCoeff(), 1e-12) << "shot " << shot;
    // The whole-matrix route on Eigen agrees with the block route.
    EXPECT_LT((on_blas.Mean() - on_eigen.Mean()).cwiseAbs().maxCoeff(), 1e-9) << "shot " << shot;
    EXPECT_LT((on_blas.Covariance() - on_eigen.Covariance()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_EQ(on_blas.Covariance(), on_blas.Covariance().transpose());
    // Variances stay positive: a near-certain cell ends near 1e-6, not below 0.
    EXPECT_GT(on_blas.Covariance().diagonal().minCoeff(), 0.0);
  }
  EXPECT_GE(all_seen, 1);
}

TEST_F(DenseBackendTest, ConcurrentCallsGiveTheSingleThreadedResultsBitForBit) {
  // The server's planning and measurement threads call the backend at the same
  // time. Each thread repeats the same solves and rank updates and must get
  // what one thread alone gets, to the bit. Debian's serial OpenBLAS, which
  // hands out scratch buffers without a lock, failed this before
  // DenseBackend::OpenBlas() refused it: small calls, many of them, make the race
  // likely.
  std::mt19937 rng(5);
  std::normal_distribution<double> normal;
  constexpr int kThreads = 4;
  constexpr int kRepeats = 5000;
  struct Work {
    Eigen::MatrixXd lower, b, p;
  };
  std::vector<Work> work;
  for (int t = 0; t < kThreads; ++t) {
    const int m = 16 + t;
    const int k = 32 + t;
    Eigen::MatrixXd a(m, m);
    for (double& v : a.reshaped()) v = normal(rng);
    Work w;
    w.lower = Eigen::LLT<Eigen::MatrixXd>(a * a.transpose() + m * Eigen::MatrixXd::Identity(m, m))
                  .matrixLLT();
    w.b.resize(m, k);
    for (double& v : w.b.reshaped()) v = normal(rng);
    w.p = Eigen::MatrixXd::Identity(k, k);
    work.push_back(std::move(w));
  }
  auto run = [this](const Work& w) {
    Eigen::MatrixXd x = w.b;
    blas_.SolveLeftLower(w.lower, x);
    Eigen::MatrixXd p = w.p;
    blas_.SymmetricRankUpdate(-1e-3, x.transpose(), p);
    return std::pair{x, p};
  };
  std::vector<std::pair<Eigen::MatrixXd, Eigen::MatrixXd>> alone;
  for (const Work& w : work) alone.push_back(run(w));
  std::vector<int> mismatches(kThreads, 0);
  {
    std::vector<std::jthread> threads;
    for (int t = 0; t < kThreads; ++t) {
      threads.emplace_back([&, t] {
        for (int r = 0; r < kRepeats; ++r) {
          const auto [x, p] = run(work[t]);
          if (x != alone[t].first || p != alone[t].second) ++mismatches[t];
        }
      });
    }
  }
  for (int t = 0; t < kThreads; ++t) EXPECT_EQ(mismatches[t], 0) << "thread " << t;
}

TEST(BlasFactsTest, TheProgramRunsWithThePthreadsBuild) {
  // The pthreads build is the only one safe for concurrent callers; the
  // build links it from its own folder so that no system alternative can
  // swap it (core/mapping/CMakeLists.txt).
  const BlasFacts facts = ReadBlasFacts();
  EXPECT_EQ(facts.build, "pthreads");
  EXPECT_FALSE(facts.kernel.empty());
  EXPECT_GE(facts.threads, 1);
  EXPECT_TRUE(CheckBlasIsSafeForConcurrentCalls().ok());
}

TEST_F(DenseBackendTest, SinglePrecisionSolvesAgreeWithEigenAcrossSizes) {
  // OpenBLAS 0.3.21's Prescott strtri_ faulted from n = 133: the sizes
  // around it and up to the largest window the objective factors, on
  // whichever kernels this machine runs (Eigen's where they are not used).
  std::mt19937 rng(11);
  std::normal_distribution<float> normal;
  for (const int n : {1, 2, 3, 7, 16, 64, 131, 132, 133, 134, 200, 257, 400, 700}) {
    Eigen::MatrixXf a(n, n);
    for (float& v : a.reshaped()) v = normal(rng);
    const Eigen::MatrixXf spd =
        a * a.transpose() / static_cast<float>(n) + Eigen::MatrixXf::Identity(n, n);
    Eigen::MatrixXf on_blas = spd;
    Eigen::MatrixXf on_eigen = spd;
    ASSERT_TRUE(blas_.CholeskyLowerInPlace(on_blas)) << n;
    ASSERT_TRUE(eigen_.CholeskyLowerInPlace(on_eigen)) << n;
    const Eigen::MatrixXf l_blas = on_blas.triangularView<Eigen::Lower>();
    const Eigen::MatrixXf l_eigen = on_eigen.triangularView<Eigen::Lower>();
    EXPECT_LT((l_blas - l_eigen).cwiseAbs().maxCoeff(), 1e-4F) << n;
    // The factor reproduces the matrix (a check outside both libraries).
    EXPECT_LT((l_blas * l_blas.transpose() - spd).cwiseAbs().maxCoeff(), 1e-4F) << n;
    Eigen::MatrixXf b(n, 5);
    for (float& v : b.reshaped()) v = normal(rng);
    Eigen::MatrixXf x = b;
    blas_.SolveLeftLower(l_blas, x);
    EXPECT_LT((l_blas * x - b).cwiseAbs().maxCoeff(), 1e-3F) << n;
    Eigen::MatrixXf inverse = l_blas;
    blas_.InverseLowerInPlace(inverse);
    const Eigen::MatrixXf inv_lower = inverse.triangularView<Eigen::Lower>();
    EXPECT_LT((inv_lower * l_blas - Eigen::MatrixXf::Identity(n, n)).cwiseAbs().maxCoeff(), 1e-3F)
        << n;
  }
}

}  // namespace
}  // namespace oaipp
