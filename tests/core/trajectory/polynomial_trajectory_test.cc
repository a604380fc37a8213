#include "core/trajectory/polynomial_trajectory.h"

#include <cmath>
#include <random>

#include "core/trajectory/min_snap.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/trajectory/test_util.h"

namespace oaipp {
namespace {

using ::testing::HasSubstr;
using testing::RandomVector;
using testing::RandomWaypoints;

PolynomialTrajectory RestToRest(const Vec3& from, const Vec3& to, double T) {
  return *SolveMinSnap({from, to}, {T}, Vec3::Zero(), Vec3::Zero());
}

// Peaks of the docs/reference-values.md §6.1 rest-to-rest polynomial, from sympy:
// speed 2.4609375 D / T at s = 1/2, acceleration 9.3719762184941037 D / T^2
// at s = 1/2 -+ sqrt(7)/14.
TEST(PolynomialTrajectoryTest, SingleSegmentPeaksMatchClosedForm) {
  for (double T : {0.1, 2.0, 60.0}) {
    const Vec3 d(3, -4, 12);  // |d| = 13
    const PolynomialTrajectory traj = RestToRest(Vec3::Zero(), d, T);
    EXPECT_NEAR(traj.MaxSpeed(), 2.4609375 * 13 / T, 1e-10 * 13 / T) << T;
    EXPECT_NEAR(traj.MaxAcceleration(), 9.3719762184941037 * 13 / (T * T), 1e-10 * 13 / (T * T))
        << T;
  }
}

TEST(PolynomialTrajectoryTest, MaxSpeedAndAccelerationMatchBruteForceSampling) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> dur(0.5, 8.0);
  for (int trial = 0; trial < 10; ++trial) {
    const int n = 1 + trial;
    std::vector<double> T(n);
    for (double& t : T) t = dur(rng);
    const auto traj = SolveMinSnap(RandomWaypoints(rng, n + 1), T, RandomVector(rng, 5.0),
                                   RandomVector(rng, 3.0));
    ASSERT_TRUE(traj.ok()) << traj.status();
    double speed = 0.0, accel = 0.0;
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i <= 20000; ++i) {
        const double t = traj->SegmentStartTime(j) + T[j] * i / 20000.0;
        speed = std::max(speed, traj->Velocity(t).norm());
        accel = std::max(accel, traj->Acceleration(t).norm());
      }
    }
    // Brute force can only under-estimate, by at most ~(T/20000)^2 curvature.
    EXPECT_GE(traj->MaxSpeed(), speed * (1 - 1e-12)) << trial;
    EXPECT_LE(traj->MaxSpeed(), speed * (1 + 1e-6)) << trial;
    EXPECT_GE(traj->MaxAcceleration(), accel * (1 - 1e-12)) << trial;
    EXPECT_LE(traj->MaxAcceleration(), accel * (1 + 1e-6)) << trial;
  }
}

TEST(PolynomialTrajectoryTest, QueriesOutsideTheTimeRangeAreClamped) {
  const PolynomialTrajectory traj = RestToRest(Vec3::Zero(), Vec3(1, 2, 3), 2.0);
  EXPECT_EQ(traj.Position(-1.0), traj.Position(0.0));
  EXPECT_EQ(traj.Position(5.0), traj.Position(2.0));
  EXPECT_LE((traj.Position(5.0) - Vec3(1, 2, 3)).norm(), 1e-12);
  EXPECT_EQ(traj.Velocity(5.0), traj.Velocity(2.0));
}

TEST(PolynomialTrajectoryTest, DerivativesAboveDegreeNineAreZero) {
  const PolynomialTrajectory traj = RestToRest(Vec3::Zero(), Vec3(5, 0, 0), 5.0);
  // d^9/dt^9 of 5 * 70 s^9 = 5 * 70 * 9! / T^9.
  EXPECT_NEAR(traj.Derivative(1.0, 9).x(), 5 * 70 * 362880.0 / std::pow(5.0, 9), 1e-9);
  EXPECT_EQ(traj.Derivative(1.0, 10), Vec3::Zero());
}

TEST(PolynomialTrajectoryTest, SegmentTimesAddUpToTheDuration) {
  const auto traj = SolveMinSnap({Vec3::Zero(), Vec3::Ones(), Vec3::UnitX(), Vec3::UnitY()},
                                 {0.5, 1.25, 2.0}, Vec3::Zero(), Vec3::Zero());
  ASSERT_TRUE(traj.ok());
  EXPECT_EQ(traj->NumSegments(), 3);
  EXPECT_DOUBLE_EQ(traj->SegmentStartTime(1), 0.5);
  EXPECT_DOUBLE_EQ(traj->SegmentStartTime(2), 1.75);
  EXPECT_DOUBLE_EQ(traj->SegmentStartTime(3), 3.75);
  EXPECT_DOUBLE_EQ(traj->Duration(), 3.75);
}

TEST(PolynomialTrajectoryTest, CopiesAreIndependentValues) {
  PolynomialTrajectory a = RestToRest(Vec3::Zero(), Vec3(1, 0, 0), 1.0);
  const PolynomialTrajectory b = a;
  a = RestToRest(Vec3::Zero(), Vec3(0, 5, 0), 3.0);
  EXPECT_LE((b.Position(1.0) - Vec3(1, 0, 0)).norm(), 1e-12);
  EXPECT_LE((a.Position(3.0) - Vec3(0, 5, 0)).norm(), 1e-12);
}

// A trajectory rebuilt from its real-time coefficients (what a client
// receives) matches the original to round-off in every derivative up to
// snap, on random multi-segment trajectories.
TEST(PolynomialTrajectoryTest, FromCoefficientsReproducesTheTrajectory) {
  std::mt19937 rng(17);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 1 + trial % 4;
    std::vector<double> T;
    for (int i = 0; i < n; ++i) T.push_back(std::uniform_real_distribution<double>(0.5, 4.0)(rng));
    const auto traj = SolveMinSnap(RandomWaypoints(rng, n + 1), T, RandomVector(rng, 3.0),
                                   RandomVector(rng, 2.0));
    ASSERT_TRUE(traj.ok()) << traj.status();
    std::vector<PolynomialTrajectory::SegmentCoefficients> c;
    for (int i = 0; i < n; ++i) c.push_back(traj->Coefficients(i));
    const auto copy = PolynomialTrajectory::FromCoefficients(traj->SegmentDurations(), c);
    ASSERT_TRUE(copy.ok()) << copy.status();
    EXPECT_EQ(copy->Duration(), traj->Duration());
    for (int i = 0; i <= n; ++i) {
      EXPECT_LT((copy->Waypoints()[i] - traj->Waypoints()[i]).norm(), 1e-9) << i;
    }
    for (double t = 0.0; t <= traj->Duration(); t += 0.013) {
      for (int order = 0; order <= 4; ++order) {
        const Vec3 want = traj->Derivative(t, order);
        EXPECT_LT((copy->Derivative(t, order) - want).norm(), 1e-8 * (1.0 + want.norm()))
            << "t " << t << " order " << order;
      }
    }
    EXPECT_NEAR(copy->SnapCost(), traj->SnapCost(), 1e-8 * traj->SnapCost());
  }
}

// p(tau) = 1 + 2 tau - tau^3 + 0.5 tau^9 on x: the value and the first three
// derivatives in closed form at tau = 0.7.
TEST(PolynomialTrajectoryTest, RealTimeCoefficientsEvaluateInClosedForm) {
  PolynomialTrajectory::SegmentCoefficients c = PolynomialTrajectory::SegmentCoefficients::Zero();
  c(0, 0) = 1.0;
  c(1, 0) = 2.0;
  c(3, 0) = -1.0;
  c(9, 0) = 0.5;
  const auto traj = PolynomialTrajectory::FromCoefficients({2.0}, {c});
  ASSERT_TRUE(traj.ok()) << traj.status();
  const double t = 0.7;
  EXPECT_NEAR(traj->Position(t).x(), 1 + 2 * t - t * t * t + 0.5 * std::pow(t, 9), 1e-15);
  EXPECT_NEAR(traj->Velocity(t).x(), 2 - 3 * t * t + 4.5 * std::pow(t, 8), 1e-14);
  EXPECT_NEAR(traj->Acceleration(t).x(), -6 * t + 36 * std::pow(t, 7), 1e-13);
  EXPECT_NEAR(traj->Derivative(t, 3).x(), -6 + 252 * std::pow(t, 6), 1e-12);
  EXPECT_EQ(traj->Position(t).y(), 0.0);
  EXPECT_EQ(traj->Waypoints().back().x(), 1 + 2 * 2 - 8 + 0.5 * 512);
}

TEST(PolynomialTrajectoryTest, FromCoefficientsRefusesBadInput) {
  const PolynomialTrajectory::SegmentCoefficients c =
      PolynomialTrajectory::SegmentCoefficients::Zero();
  EXPECT_THAT(PolynomialTrajectory::FromCoefficients({}, {}).status().message(),
              ::testing::HasSubstr("durations_s"));
  EXPECT_THAT(PolynomialTrajectory::FromCoefficients({1.0, 2.0}, {c}).status().message(),
              ::testing::HasSubstr("coefficients"));
  EXPECT_THAT(PolynomialTrajectory::FromCoefficients({0.0}, {c}).status().message(),
              ::testing::HasSubstr("durations_s[0]"));
  PolynomialTrajectory::SegmentCoefficients bad = c;
  bad(3, 1) = NAN;
  EXPECT_THAT(PolynomialTrajectory::FromCoefficients({1.0}, {bad}).status().message(),
              ::testing::HasSubstr("coefficients[0]"));
}

TEST(SampleTrajectoryTest, SamplesAtTheRateAndIncludesBothEnds) {
  const PolynomialTrajectory traj = RestToRest(Vec3::Zero(), Vec3(4, 0, 0), 1.03);
  const auto samples = SampleTrajectory(traj, 20.0);
  ASSERT_TRUE(samples.ok()) << samples.status();
  // t = 0, 0.05, .., 1.00 (21 samples) and the end, 1.03.
  ASSERT_EQ(samples->size(), 22u);
  for (size_t i = 0; i + 1 < samples->size(); ++i) {
    EXPECT_NEAR((*samples)[i].t_s, i / 20.0, 1e-15);
    EXPECT_EQ((*samples)[i].position_W, traj.Position((*samples)[i].t_s));
  }
  EXPECT_EQ(samples->back().t_s, 1.03);
  EXPECT_LE((samples->back().position_W - Vec3(4, 0, 0)).norm(), 1e-12);
}

TEST(SampleTrajectoryTest, DurationOnTheGridIsNotSampledTwice) {
  const PolynomialTrajectory traj = RestToRest(Vec3::Zero(), Vec3(4, 0, 0), 1.0);
  const auto samples = SampleTrajectory(traj, 4.0);
  ASSERT_TRUE(samples.ok());
  ASSERT_EQ(samples->size(), 5u);  // 0, 0.25, 0.5, 0.75, 1
  EXPECT_EQ(samples->back().t_s, 1.0);
}

TEST(SampleTrajectoryTest, RejectsBadRates) {
  const PolynomialTrajectory traj = RestToRest(Vec3::Zero(), Vec3(4, 0, 0), 1.0);
  for (double bad : {0.0, -20.0, std::nan(""), double{INFINITY}, 1e12}) {
    const auto r = SampleTrajectory(traj, bad);
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_THAT(r.status().message(), HasSubstr("rate_hz"));
  }
}

}  // namespace
}  // namespace oaipp
