#include "core/trajectory/min_snap.h"

#include <cmath>
#include <random>
#include <tuple>

#include "Eigen/Dense"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/trajectory/test_util.h"

namespace oaipp {
namespace {

using testing::EvalRealTime;
using ::testing::HasSubstr;
using testing::RandomVector;
using testing::RandomWaypoints;

// docs/reference-values.md §6 "Minimum-snap polynomials": rest-to-rest single segment,
// D (126 s^5 - 420 s^6 + 540 s^7 - 315 s^8 + 70 s^9), s = t / T.
constexpr double kRestToRest[10] = {0, 0, 0, 0, 0, 126, -420, 540, -315, 70};
constexpr double kRestToRestCost = 1814400.0 / 11.0;  // times D^2 / T^7

PolynomialTrajectory Solve(const std::vector<Vec3>& w, const std::vector<double>& T,
                           const Vec3& v0 = Vec3::Zero(), const Vec3& a0 = Vec3::Zero()) {
  auto traj = SolveMinSnap(w, T, v0, a0);
  EXPECT_TRUE(traj.ok()) << traj.status();
  return *std::move(traj);
}

TEST(MinSnapReferenceTest, SingleSegmentRestToRestCoefficientsMatchReference) {
  const Vec3 d(5.0, -2.0, 0.5);
  const double T = 5.0;
  const PolynomialTrajectory traj = Solve({Vec3::Zero(), d}, {T});
  const auto c = traj.Coefficients(0);
  for (int k = 0; k < 10; ++k) {
    for (int a = 0; a < 3; ++a) {
      // Real-time coefficient of tau^k is D b_k / T^k.
      const double expected = d[a] * kRestToRest[k] / std::pow(T, k);
      EXPECT_NEAR(c(k, a), expected, 1e-9 * std::abs(d[a] * kRestToRest[9] / std::pow(T, k)))
          << "k=" << k << " axis " << a;
    }
  }
}

TEST(MinSnapReferenceTest, SingleSegmentCostMatchesClosedFormAcrossDurations) {
  const Vec3 p0(1.0, 2.0, 3.0), d(5.0, 0.0, -1.0);
  for (double T : {0.1, 0.5, 1.0, 5.0, 60.0}) {
    const PolynomialTrajectory traj = Solve({p0, p0 + d}, {T});
    const double expected = kRestToRestCost * d.squaredNorm() / std::pow(T, 7);
    EXPECT_NEAR(traj.SnapCost(), expected, 1e-9 * expected) << "T = " << T;
  }
}

// docs/reference-values.md: 1-D waypoints [0, 1, 3], T = [1, 1].
TEST(MinSnapReferenceTest, ThreeWaypointCostAndInteriorDerivativesMatchReference) {
  const PolynomialTrajectory traj =
      Solve({Vec3::Zero(), Vec3::UnitX(), 3.0 * Vec3::UnitX()}, {1, 1});
  EXPECT_NEAR(traj.SnapCost(), 19590.26087, 1e-6 * 19590.26087);
  const double expected[5] = {1.0, 3.4125, 4.565217, -23.1, -142.434783};
  for (int r = 0; r <= 4; ++r) {
    const Vec3 left = EvalRealTime(traj.Coefficients(0), 1.0, r);
    const Vec3 right = EvalRealTime(traj.Coefficients(1), 0.0, r);
    EXPECT_NEAR(left.x(), expected[r], 1e-6 * std::abs(expected[r])) << "order " << r;
    EXPECT_NEAR(right.x(), expected[r], 1e-6 * std::abs(expected[r])) << "order " << r;
    EXPECT_EQ(left.y(), 0.0);
    EXPECT_EQ(left.z(), 0.0);
  }
}

TEST(MinSnapReferenceTest, DoublingDurationsScalesCostByTwoToTheMinusSeven) {
  const std::vector<Vec3> w{Vec3::Zero(), Vec3::UnitX(), 3.0 * Vec3::UnitX()};
  const double j1 = Solve(w, {1, 1}).SnapCost();
  const double j2 = Solve(w, {2, 2}).SnapCost();
  EXPECT_NEAR(j2, j1 / 128.0, 1e-12 * j1);
  EXPECT_NEAR(j2, 19590.26087 / 128.0, 1e-6 * j2);
}

// An independent twin: the textbook dense KKT system over all 10 N
// coefficients per axis in real time (the constrained QP of Richter et al.
// 2016, with equality constraints for fixed and continuous derivatives),
// equilibrated and solved by LU in long double.
Eigen::MatrixXd KktCoefficients(const std::vector<double>& w, const std::vector<double>& T,
                                double v0, double a0, bool free_start_jerk_snap = false) {
  const int n = static_cast<int>(T.size());
  const int vars = 10 * n;
  const auto ff = [](int k, int r) {
    double f = 1;
    for (int i = 0; i < r; ++i) f *= k - i;
    return f;
  };
  // Row of d^r/dtau^r at tau for segment j.
  const auto deriv_row = [&](int j, double tau, int r) {
    Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(vars);
    for (int k = r; k < 10; ++k) row(10 * j + k) = ff(k, r) * std::pow(tau, k - r);
    return row;
  };
  std::vector<Eigen::RowVectorXd> rows;
  std::vector<double> rhs;
  const double start[5] = {w[0], v0, a0, 0, 0};
  for (int r = 0; r < (free_start_jerk_snap ? 3 : 5); ++r) {
    rows.push_back(deriv_row(0, 0, r)), rhs.push_back(start[r]);
  }
  for (int j = 0; j < n; ++j) {
    rows.push_back(deriv_row(j, T[j], 0)), rhs.push_back(w[j + 1]);
    if (j + 1 < n) {
      rows.push_back(deriv_row(j + 1, 0, 0)), rhs.push_back(w[j + 1]);
      for (int r = 1; r <= 4; ++r) {
        rows.push_back(deriv_row(j, T[j], r) - deriv_row(j + 1, 0, r)), rhs.push_back(0);
      }
    }
  }
  for (int r = 1; r <= 4; ++r) rows.push_back(deriv_row(n - 1, T[n - 1], r)), rhs.push_back(0);
  const int m = static_cast<int>(rows.size());
  Eigen::MatrixXd kkt = Eigen::MatrixXd::Zero(vars + m, vars + m);
  for (int j = 0; j < n; ++j) {
    for (int i = 4; i < 10; ++i) {
      for (int k = 4; k < 10; ++k) {
        kkt(10 * j + i, 10 * j + k) =
            2 * ff(i, 4) * ff(k, 4) * std::pow(T[j], i + k - 7) / (i + k - 7);
      }
    }
  }
  Eigen::VectorXd b = Eigen::VectorXd::Zero(vars + m);
  for (int i = 0; i < m; ++i) {
    kkt.block(vars + i, 0, 1, vars) = rows[i];
    kkt.block(0, vars + i, vars, 1) = rows[i].transpose();
    b(vars + i) = rhs[i];
  }
  // Symmetric equilibration, then partial-pivot LU in long double: the
  // system is regular but its entries span ~10 orders of magnitude.
  using MatrixL = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
  using VectorL = Eigen::Matrix<long double, Eigen::Dynamic, 1>;
  const Eigen::VectorXd d = kkt.cwiseAbs().rowwise().maxCoeff().cwiseSqrt().cwiseInverse();
  const MatrixL scaled = (d.asDiagonal() * kkt * d.asDiagonal()).cast<long double>();
  const VectorL y = scaled.partialPivLu().solve((d.asDiagonal() * b).cast<long double>());
  const Eigen::VectorXd x = d.asDiagonal() * y.cast<double>();
  EXPECT_LE((kkt * x - b).norm(), 1e-9 * kkt.norm() * x.norm()) << "the twin did not solve";
  return x.head(vars).reshaped(10, n);
}

// Every coefficient of `traj` against the dense twin, per axis and segment.
void ExpectMatchesTwin(const PolynomialTrajectory& traj, const std::vector<Vec3>& w,
                       const std::vector<double>& T, const Vec3& v0, const Vec3& a0,
                       bool free_start_jerk_snap, int trial) {
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> w1;
    for (const auto& p : w) w1.push_back(p[axis]);
    const Eigen::MatrixXd c = KktCoefficients(w1, T, v0[axis], a0[axis], free_start_jerk_snap);
    for (int j = 0; j < static_cast<int>(T.size()); ++j) {
      const Eigen::VectorXd mine = traj.Coefficients(j).col(axis);
      EXPECT_LE((mine - c.col(j)).norm(), 1e-7 * std::max(1.0, c.col(j).norm()))
          << "trial " << trial << " segment " << j << " axis " << axis;
    }
  }
}

// A random problem of n segments: waypoints in [-3, 3]^3, durations in
// [0.5, max_duration_s], start velocity and acceleration components in
// [-max_start, max_start].
struct TwinProblem {
  std::vector<Vec3> w;
  std::vector<double> T;
  Vec3 v0, a0;
};

TwinProblem RandomTwinProblem(std::mt19937& rng, int n, double max_duration_s, double max_start) {
  std::uniform_real_distribution<double> dur(0.5, max_duration_s), pos(-3.0, 3.0),
      small(-max_start, max_start);
  TwinProblem p{std::vector<Vec3>(n + 1), std::vector<double>(n), Vec3::Zero(), Vec3::Zero()};
  for (auto& q : p.w) q = Vec3(pos(rng), pos(rng), pos(rng));
  for (auto& t : p.T) t = dur(rng);
  p.v0 = Vec3(small(rng), small(rng), small(rng));
  p.a0 = Vec3(small(rng), small(rng), small(rng));
  return p;
}

TEST(MinSnapTwinTest, MatchesDenseKktSolutionForRandomProblems) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 20; ++trial) {
    const auto [w, T, v0, a0] = RandomTwinProblem(rng, 1 + trial % 5, 2.0, 1.0);
    ExpectMatchesTwin(Solve(w, T, v0, a0), w, T, v0, a0, false, trial);
  }
}

// With the start jerk and snap left free (no start constraints on them in
// the twin), the closed-form elimination matches the dense solution, and
// it never costs more than the constrained problem.
TEST(MinSnapTwinTest, FreeStartJerkAndSnapMatchDenseKkt) {
  std::mt19937 rng(13);
  for (int trial = 0; trial < 20; ++trial) {
    const auto [w, T, v0, a0] = RandomTwinProblem(rng, 1 + trial % 5, 4.0, 2.0);
    absl::StatusOr<PolynomialTrajectory> free = SolveMinSnap(w, T, v0, a0, true);
    ASSERT_TRUE(free.ok()) << free.status();
    const PolynomialTrajectory fixed = Solve(w, T, v0, a0);
    EXPECT_LE(free->SnapCost(), fixed.SnapCost() * (1 + 1e-9)) << "trial " << trial;
    EXPECT_LE((free->Velocity(0) - v0).norm(), 1e-9);
    EXPECT_LE((free->Acceleration(0) - a0).norm(), 1e-9);
    ExpectMatchesTwin(*free, w, T, v0, a0, true, trial);
  }
}

// Durations: realistic (0.5..10 s) or mixed freely over 0.1..60 s.
enum class Durations { kRealistic, kExtreme };

class MinSnapRandomTest : public ::testing::TestWithParam<std::tuple<unsigned, int, Durations>> {
 protected:
  void SetUp() override {
    const auto [seed, segments, durations] = GetParam();
    std::mt19937 rng(seed);
    waypoints_ = RandomWaypoints(rng, segments + 1);
    std::uniform_real_distribution<double> realistic(0.5, 10.0),
        log_t(std::log(0.1), std::log(60.0));
    for (int j = 0; j < segments; ++j) {
      durations_.push_back(durations == Durations::kRealistic ? realistic(rng)
                                                              : std::exp(log_t(rng)));
    }
    v0_ = RandomVector(rng, 5.0);
    a0_ = RandomVector(rng, 3.0);
  }
  std::vector<Vec3> waypoints_;
  std::vector<double> durations_;
  Vec3 v0_, a0_;
};

// Measured worst case: ~2e-8 with durations mixed over 0.1..60 s, ~3e-12
// with 0.5..10 s.
constexpr double kContinuityTolerance = 1e-6;

TEST_P(MinSnapRandomTest, DerivativesZeroToFourContinuousAtInteriorWaypoints) {
  const PolynomialTrajectory traj = Solve(waypoints_, durations_, v0_, a0_);
  for (int j = 0; j + 1 < traj.NumSegments(); ++j) {
    for (int r = 0; r <= 4; ++r) {
      const Vec3 left = EvalRealTime(traj.Coefficients(j), durations_[j], r);
      const Vec3 right = EvalRealTime(traj.Coefficients(j + 1), 0.0, r);
      const double scale = std::max({left.norm(), right.norm(), 1e-9});
      EXPECT_LE((left - right).norm(), kContinuityTolerance * scale)
          << "waypoint " << j + 1 << " order " << r;
    }
  }
}

TEST_P(MinSnapRandomTest, PassesThroughEveryWaypoint) {
  const PolynomialTrajectory traj = Solve(waypoints_, durations_, v0_, a0_);
  ASSERT_EQ(traj.Waypoints().size(), waypoints_.size());
  for (int j = 0; j < traj.NumSegments(); ++j) {
    // Evaluating at the far end sums the coefficients in normalised time
    // s = tau / T; rounding is relative to their size (large only when a
    // long segment follows a very short one).
    double size = 1.0;
    for (int k = 0; k < 10; ++k) {
      size = std::max(size, traj.Coefficients(j).row(k).norm() * std::pow(durations_[j], k));
    }
    const double t0 = traj.SegmentStartTime(j);
    EXPECT_LE((traj.Position(t0) - waypoints_[j]).norm(), 1e-12 * size) << j;
    EXPECT_LE((EvalRealTime(traj.Coefficients(j), durations_[j], 0) - waypoints_[j + 1]).norm(),
              1e-12 * size)
        << j;
    if (j + 1 == traj.NumSegments()) {
      EXPECT_LE((traj.Position(traj.Duration()) - waypoints_.back()).norm(), 1e-12 * size);
    }
  }
}

TEST_P(MinSnapRandomTest, StartsWithGivenVelocityAndAccelerationAndEndsAtRest) {
  const PolynomialTrajectory traj = Solve(waypoints_, durations_, v0_, a0_);
  EXPECT_LE((traj.Velocity(0.0) - v0_).norm(), 1e-12);
  EXPECT_LE((traj.Acceleration(0.0) - a0_).norm(), 1e-12);
  EXPECT_LE(traj.Derivative(0.0, 3).norm(), 1e-12);
  EXPECT_LE(traj.Derivative(0.0, 4).norm(), 1e-12);
  // At the end, relative to the derivative's size over the last segment.
  const int last = traj.NumSegments() - 1;
  for (int r = 1; r <= 4; ++r) {
    const double scale = EvalRealTime(traj.Coefficients(last), 0.0, r).norm() +
                         EvalRealTime(traj.Coefficients(last), 0.5 * durations_[last], r).norm();
    EXPECT_LE(traj.Derivative(traj.Duration(), r).norm(), 1e-9 * std::max(scale, 1.0))
        << "order " << r;
  }
}

TEST_P(MinSnapRandomTest, ClosedFormSnapCostMatchesSimpsonIntegration) {
  const PolynomialTrajectory traj = Solve(waypoints_, durations_, v0_, a0_);
  const double simpson = testing::SimpsonSnapCost(traj, 200);
  EXPECT_NEAR(traj.SnapCost(), simpson, 0.01 * simpson);
}

TEST_P(MinSnapRandomTest, CoefficientsAgreeWithDerivativeInsideSegments) {
  const PolynomialTrajectory traj = Solve(waypoints_, durations_, v0_, a0_);
  for (int j = 0; j < traj.NumSegments(); ++j) {
    const double tau = 0.37 * durations_[j];
    for (int r = 0; r <= 4; ++r) {
      const Vec3 a = EvalRealTime(traj.Coefficients(j), tau, r);
      const Vec3 b = traj.Derivative(traj.SegmentStartTime(j) + tau, r);
      EXPECT_LE((a - b).norm(), 1e-7 * std::max(a.norm(), 1.0)) << j << " " << r;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(
    SeedsSegmentsDurations, MinSnapRandomTest,
    ::testing::Combine(::testing::Values(1u, 2u, 3u), ::testing::Values(1, 10, 50),
                       ::testing::Values(Durations::kRealistic, Durations::kExtreme)),
    [](const auto& param_info) {
      return "seed" + std::to_string(std::get<0>(param_info.param)) + "_" +
             std::to_string(std::get<1>(param_info.param)) + "segments_" +
             (std::get<2>(param_info.param) == Durations::kRealistic ? "realistic" : "extreme");
    });

TEST(MinSnapInputTest, RejectsFewerThanTwoWaypoints) {
  const auto r = SolveMinSnap({Vec3::Zero()}, {}, Vec3::Zero(), Vec3::Zero());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r.status().message(), HasSubstr("waypoints_W"));
  EXPECT_FALSE(SolveMinSnap({}, {}, Vec3::Zero(), Vec3::Zero()).ok());
}

TEST(MinSnapInputTest, RejectsDurationCountMismatch) {
  const auto r = SolveMinSnap({Vec3::Zero(), Vec3::Ones()}, {1.0, 1.0}, Vec3::Zero(), Vec3::Zero());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r.status().message(), HasSubstr("segment_durations_s"));
}

TEST(MinSnapInputTest, RejectsNonPositiveOrNonFiniteDurations) {
  const std::vector<Vec3> w{Vec3::Zero(), Vec3::Ones(), Vec3::UnitX()};
  for (double bad : {0.0, -1.0, std::nan(""), double{INFINITY}}) {
    const auto r = SolveMinSnap(w, {1.0, bad}, Vec3::Zero(), Vec3::Zero());
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_THAT(r.status().message(), HasSubstr("segment_durations_s[1]"));
  }
}

TEST(MinSnapInputTest, RejectsNonFiniteWaypointsAndStartState) {
  const Vec3 nan_v(0.0, std::nan(""), 0.0);
  const auto r1 = SolveMinSnap({Vec3::Zero(), nan_v}, {1.0}, Vec3::Zero(), Vec3::Zero());
  EXPECT_EQ(r1.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r1.status().message(), HasSubstr("waypoints_W[1]"));
  const auto r2 = SolveMinSnap({Vec3::Zero(), Vec3::Ones()}, {1.0}, nan_v, Vec3::Zero());
  EXPECT_THAT(r2.status().message(), HasSubstr("start_velocity_W_m_s"));
  const auto r3 = SolveMinSnap({Vec3::Zero(), Vec3::Ones()}, {1.0}, Vec3::Zero(), nan_v);
  EXPECT_THAT(r3.status().message(), HasSubstr("start_accel_W_m_s2"));
}

TEST(MinSnapInputTest, RepeatedWaypointsAreAllowed) {
  const auto r = SolveMinSnap({Vec3::Zero(), Vec3::Ones(), Vec3::Ones(), Vec3::UnitX()}, {1, 1, 1},
                              Vec3::Zero(), Vec3::Zero());
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_LE((r->Position(2.0) - Vec3::Ones()).norm(), 1e-12);
}

}  // namespace
}  // namespace oaipp
