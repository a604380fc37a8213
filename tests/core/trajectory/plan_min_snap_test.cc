#include <cmath>
#include <iostream>
#include <random>

#include "core/trajectory/min_snap.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/trajectory/test_util.h"

namespace oaipp {
namespace {

using ::testing::HasSubstr;
using testing::RandomPoint;
using testing::RandomVector;
using testing::RandomWaypoints;

const TrajectoryLimits kPaperLimits{.max_speed_m_s = 5.0, .max_accel_m_s2 = 3.0};

// docs/reference-values.md §7 "Segment time from a velocity ramp".
TEST(RampSegmentTimeTest, MatchesReferenceValues) {
  EXPECT_NEAR(RampSegmentTime(1.0, kPaperLimits), 1.1547, 1e-4);
  EXPECT_NEAR(RampSegmentTime(5.0, kPaperLimits), 2.5820, 1e-4);
  EXPECT_NEAR(RampSegmentTime(10.0, kPaperLimits), 3.6667, 1e-4);
  EXPECT_NEAR(RampSegmentTime(20.0, kPaperLimits), 5.6667, 1e-4);
  EXPECT_EQ(RampSegmentTime(0.0, kPaperLimits), 0.0);
}

TEST(RampSegmentTimeTest, ContinuousWhereCruiseBegins) {
  const double d = 25.0 / 3.0;  // v^2 / a
  EXPECT_NEAR(RampSegmentTime(d * (1 - 1e-12), kPaperLimits), RampSegmentTime(d, kPaperLimits),
              1e-9);
}

// The limits checked by dense sampling (1000 per segment) through the
// public Velocity/Acceleration, independent of MaxSpeed/MaxAcceleration.
struct SampledMaxima {
  double speed_m_s = 0.0;
  double accel_m_s2 = 0.0;
};
SampledMaxima DenseMaxima(const PolynomialTrajectory& traj) {
  SampledMaxima m;
  for (int j = 0; j < traj.NumSegments(); ++j) {
    for (int i = 0; i <= 1000; ++i) {
      const double t = traj.SegmentStartTime(j) + traj.SegmentDurations()[j] * i / 1000.0;
      m.speed_m_s = std::max(m.speed_m_s, traj.Velocity(t).norm());
      m.accel_m_s2 = std::max(m.accel_m_s2, traj.Acceleration(t).norm());
    }
  }
  return m;
}

// Paper settings (docs/method.md §5): N = 3 control waypoints, and a few more.
class PlanMinSnapFromRestTest : public ::testing::TestWithParam<unsigned> {};

TEST_P(PlanMinSnapFromRestTest, MeetsLimitsOnDenseSamplingAndOneIsTight) {
  std::mt19937 rng(GetParam());
  for (int trial = 0; trial < 40; ++trial) {
    const StartState start{RandomPoint(rng), Vec3::Zero(), Vec3::Zero()};
    const auto traj = PlanMinSnap(start, RandomWaypoints(rng, 1 + trial % 6), kPaperLimits);
    ASSERT_TRUE(traj.ok()) << traj.status();
    const SampledMaxima m = DenseMaxima(*traj);
    EXPECT_LE(m.speed_m_s, 5.0 * (1 + 1e-6)) << "trial " << trial;
    EXPECT_LE(m.accel_m_s2, 3.0 * (1 + 1e-6)) << "trial " << trial;
    // The fastest common scaling: one limit is reached (sampling may fall
    // just short of the peak).
    EXPECT_GE(std::max(m.speed_m_s / 5.0, m.accel_m_s2 / 3.0), 0.999) << "trial " << trial;
  }
}

TEST_P(PlanMinSnapFromRestTest, DurationsAreOneCommonMultipleOfTheRampTimes) {
  std::mt19937 rng(100 + GetParam());
  const StartState start{RandomPoint(rng), Vec3::Zero(), Vec3::Zero()};
  const auto w = RandomWaypoints(rng, 5);
  const auto traj = PlanMinSnap(start, w, kPaperLimits);
  ASSERT_TRUE(traj.ok()) << traj.status();
  std::vector<Vec3> all{start.position_W};
  all.insert(all.end(), w.begin(), w.end());
  const double k =
      traj->SegmentDurations()[0] / RampSegmentTime((all[1] - all[0]).norm(), kPaperLimits);
  for (int j = 1; j < traj->NumSegments(); ++j) {
    const double ramp_s = RampSegmentTime((all[j + 1] - all[j]).norm(), kPaperLimits);
    EXPECT_NEAR(traj->SegmentDurations()[j], k * ramp_s, 1e-9 * k * ramp_s) << j;
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, PlanMinSnapFromRestTest, ::testing::Values(1u, 2u, 3u, 4u, 5u));

// One rest-to-rest segment of length D has peak speed 2.4609375 D / T (at
// s = 1/2) and peak acceleration 9.3719762184941 D / T^2 (at
// s = 1/2 -+ sqrt(7)/14), from the docs/reference-values.md §6.1 polynomial (sympy), so the
// fastest feasible duration is max(2.4609375 D / v, sqrt(9.3719762 D / a)).
TEST(PlanMinSnapTest, SingleSegmentDurationMatchesClosedForm) {
  for (double d : {0.5, 10.0, 40.0}) {
    const auto traj = PlanMinSnap({}, {Vec3(d, 0, 0)}, kPaperLimits);
    ASSERT_TRUE(traj.ok()) << traj.status();
    const double expected = std::max(2.4609375 * d / 5.0, std::sqrt(9.3719762184941037 * d / 3.0));
    EXPECT_NEAR(traj->Duration(), expected, 1e-7 * expected) << "D = " << d;
  }
}

TEST(PlanMinSnapTest, StartsAtStartStateAndEndsAtRestOnLastWaypoint) {
  const StartState start{{1, 2, 10}, {1.5, -1, 0.5}, {0.2, 0.1, 0}};
  const std::vector<Vec3> w{{8, 4, 12}, {-3, 9, 15}, {0, -10, 6}};
  const auto traj = PlanMinSnap(start, w, kPaperLimits);
  ASSERT_TRUE(traj.ok()) << traj.status();
  EXPECT_LE((traj->Position(0) - start.position_W).norm(), 1e-12);
  EXPECT_LE((traj->Velocity(0) - start.velocity_W_m_s).norm(), 1e-12);
  EXPECT_LE((traj->Acceleration(0) - start.accel_W_m_s2).norm(), 1e-12);
  EXPECT_LE((traj->Position(traj->Duration()) - w.back()).norm(), 1e-9);
  EXPECT_LE(traj->Velocity(traj->Duration()).norm(), 1e-9);
  EXPECT_LE(traj->Acceleration(traj->Duration()).norm(), 1e-9);
  ASSERT_EQ(traj->Waypoints().size(), 4u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LE((traj->Position(traj->SegmentStartTime(i + 1)) - w[i]).norm(), 1e-9);
  }
}

// A UAV cruising (no acceleration) at up to 3 m/s in any direction.
TEST(PlanMinSnapTest, CruisingStartStatesSucceedWithinLimits) {
  std::mt19937 rng(21);
  for (int trial = 0; trial < 100; ++trial) {
    const StartState start{RandomPoint(rng), RandomVector(rng, 3.0), Vec3::Zero()};
    const auto traj = PlanMinSnap(start, RandomWaypoints(rng, 1 + trial % 4), kPaperLimits);
    ASSERT_TRUE(traj.ok()) << "trial " << trial << ": " << traj.status();
    const SampledMaxima m = DenseMaxima(*traj);
    EXPECT_LE(m.speed_m_s, 5.0 * (1 + 1e-6)) << "trial " << trial;
    EXPECT_LE(m.accel_m_s2, 3.0 * (1 + 1e-6)) << "trial " << trial;
    EXPECT_LE((traj->Velocity(0) - start.velocity_W_m_s).norm(), 1e-12);
  }
}

// Over the whole admissible start range the planner may refuse (see
// min_snap.h) but must never return a trajectory that breaks the limits.
TEST(PlanMinSnapTest, AnyStartStateWithinLimitsEitherMeetsLimitsOrFailsCleanly) {
  std::mt19937 rng(22);
  int succeeded = 0;
  for (int trial = 0; trial < 150; ++trial) {
    const StartState start{RandomPoint(rng), RandomVector(rng, 5.0), RandomVector(rng, 3.0)};
    const auto traj = PlanMinSnap(start, RandomWaypoints(rng, 1 + trial % 4), kPaperLimits);
    if (!traj.ok()) {
      EXPECT_EQ(traj.status().code(), absl::StatusCode::kFailedPrecondition) << traj.status();
      continue;
    }
    ++succeeded;
    const SampledMaxima m = DenseMaxima(*traj);
    EXPECT_LE(m.speed_m_s, 5.0 * (1 + 1e-6)) << "trial " << trial;
    EXPECT_LE(m.accel_m_s2, 3.0 * (1 + 1e-6)) << "trial " << trial;
    EXPECT_LE((traj->Velocity(0) - start.velocity_W_m_s).norm(), 1e-12);
    EXPECT_LE((traj->Acceleration(0) - start.accel_W_m_s2).norm(), 1e-12);
  }
  // With the free start jerk and the transition segment, most moving starts
  // plan: 133 of these 150 (78 with the start jerk held at 0 and no
  // transition).
  EXPECT_GE(succeeded, 130);
}

// The rate quoted in min_snap.h and docs/method.md §5.5: random moving
// starts over the whole admissible range, two waypoints each. Every
// trajectory returned meets the limits by dense sampling.
TEST(PlanMinSnapTest, MostMovingStartsPlan) {
  std::mt19937 rng(23);
  int failed = 0, failed_fast_accelerating = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const StartState start{RandomPoint(rng), RandomVector(rng, 5.0), RandomVector(rng, 3.0)};
    const auto traj = PlanMinSnap(start, RandomWaypoints(rng, 2), kPaperLimits);
    if (!traj.ok()) {
      ASSERT_EQ(traj.status().code(), absl::StatusCode::kFailedPrecondition) << traj.status();
      ++failed;
      const Vec3& v = start.velocity_W_m_s;
      if (v.norm() > 3.5 && v.dot(start.accel_W_m_s2) > 0.0) ++failed_fast_accelerating;
      continue;
    }
    const SampledMaxima m = DenseMaxima(*traj);
    ASSERT_LE(m.speed_m_s, 5.0 * (1 + 1e-6)) << "trial " << trial;
    ASSERT_LE(m.accel_m_s2, 3.0 * (1 + 1e-6)) << "trial " << trial;
  }
  std::cout << failed << " of 2000 moving starts found no trajectory, " << failed_fast_accelerating
            << " of them above 3.5 m/s and accelerating forwards\n";
  EXPECT_LE(failed, 200);
}

// Stop and go follows the polyline: every sample lies on its leg's
// segment, the UAV is at rest at every point, and the limits hold.
TEST(PlanStopAndGoTest, FollowsThePolylineAndStopsAtEveryPoint) {
  const std::vector<Vec3> points{{0, 0, 10}, {6, 0, 10}, {6, 6, 14}, {6, 6, 14}, {-3, 2, 5}};
  const auto traj = PlanStopAndGo(points, kPaperLimits);
  ASSERT_TRUE(traj.ok()) << traj.status();
  ASSERT_EQ(traj->NumSegments(), 3);  // the repeated point is skipped
  const std::vector<Vec3> ends{points[0], points[1], points[2], points[4]};
  for (int j = 0; j < 3; ++j) {
    const Vec3 a = ends[j], b = ends[j + 1];
    const double t0 = traj->SegmentStartTime(j), T = traj->SegmentDurations()[j];
    EXPECT_LE((traj->Position(t0) - a).norm(), 1e-9);
    EXPECT_LE(traj->Velocity(t0).norm(), 1e-9);
    EXPECT_LE(traj->Acceleration(t0).norm(), 1e-9);
    for (int i = 1; i <= 200; ++i) {
      const Vec3 p = traj->Position(t0 + T * i / 200.0);
      const double along = (p - a).dot((b - a).normalized());
      EXPECT_LE((p - a - along * (b - a).normalized()).norm(), 1e-9) << "leg " << j;
      EXPECT_GE(along, -1e-9);
      EXPECT_LE(along, (b - a).norm() + 1e-9);
    }
  }
  EXPECT_LE((traj->Position(traj->Duration()) - points.back()).norm(), 1e-9);
  const SampledMaxima m = DenseMaxima(*traj);
  EXPECT_LE(m.speed_m_s, 5.0 * (1 + 1e-6));
  EXPECT_LE(m.accel_m_s2, 3.0 * (1 + 1e-6));
  // Each leg takes what one rest-to-rest segment of its length takes.
  const auto first = PlanMinSnap(StartState{.position_W = points[0]}, {points[1]}, kPaperLimits);
  ASSERT_TRUE(first.ok());
  EXPECT_EQ(traj->SegmentDurations()[0], first->Duration());
}

TEST(PlanStopAndGoTest, BadInputIsRefused) {
  EXPECT_EQ(PlanStopAndGo({}, kPaperLimits).status().code(), absl::StatusCode::kInvalidArgument);
  const auto nan = PlanStopAndGo({{0, 0, 1}, {NAN, 0, 1}}, kPaperLimits);
  EXPECT_EQ(nan.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(nan.status().message()), HasSubstr("points_W"));
  const auto hover = PlanStopAndGo({{1, 2, 3}}, kPaperLimits);
  ASSERT_TRUE(hover.ok());
  EXPECT_EQ(hover->MaxSpeed(), 0.0);
}

// A replan from a path's end carries rounding residue in the velocity
// (~1e-15 m/s): it plans as from rest, start jerk and snap held at 0, while
// a real moving start leaves them free.
TEST(PlanMinSnapTest, RoundingResidueIsRestButMotionFreesTheStartJerk) {
  const Vec3 goal(10, 5, 12);
  const auto residue =
      PlanMinSnap({{0, 0, 10}, {1e-15, -2e-15, 0}, Vec3::Zero()}, {goal}, kPaperLimits);
  ASSERT_TRUE(residue.ok()) << residue.status();
  EXPECT_EQ(residue->Coefficients(0).row(3).norm(), 0.0);  // jerk / 3!
  EXPECT_EQ(residue->Coefficients(0).row(4).norm(), 0.0);  // snap / 4!
  const auto moving = PlanMinSnap({{0, 0, 10}, {1.0, 0, 0}, Vec3::Zero()}, {goal}, kPaperLimits);
  ASSERT_TRUE(moving.ok()) << moving.status();
  EXPECT_GT(moving->Coefficients(0).row(3).norm(), 1e-6);
}

TEST(PlanMinSnapTest, FullSpeedTowardsTheWaypointSucceeds) {
  const StartState start{{0, 0, 10}, {5, 0, 0}, Vec3::Zero()};
  const auto traj = PlanMinSnap(start, {{40, 0, 10}}, kPaperLimits);
  ASSERT_TRUE(traj.ok()) << traj.status();
  EXPECT_LE(DenseMaxima(*traj).speed_m_s, 5.0 * (1 + 1e-6));
}

TEST(PlanMinSnapTest, StartBeyondLimitsIsFailedPrecondition) {
  const auto fast =
      PlanMinSnap({{0, 0, 10}, {5.1, 0, 0}, Vec3::Zero()}, {{10, 0, 10}}, kPaperLimits);
  EXPECT_EQ(fast.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(fast.status().message(), HasSubstr("start.velocity_W_m_s"));
  const auto hard =
      PlanMinSnap({{0, 0, 10}, Vec3::Zero(), {0, 3.1, 0}}, {{10, 0, 10}}, kPaperLimits);
  EXPECT_EQ(hard.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(hard.status().message(), HasSubstr("start.accel_W_m_s2"));
}

TEST(PlanMinSnapTest, ConsecutiveDuplicateWaypointsAreMerged) {
  const StartState start{{0, 0, 10}, Vec3::Zero(), Vec3::Zero()};
  const Vec3 a(5, 5, 10), b(-5, 8, 12);
  const auto merged = PlanMinSnap(start, {start.position_W, a, a, b, b}, kPaperLimits);
  const auto plain = PlanMinSnap(start, {a, b}, kPaperLimits);
  ASSERT_TRUE(merged.ok()) << merged.status();
  ASSERT_TRUE(plain.ok()) << plain.status();
  ASSERT_EQ(merged->Waypoints().size(), 3u);
  EXPECT_EQ(merged->SegmentDurations(), plain->SegmentDurations());
  EXPECT_LE((merged->Position(1.3) - plain->Position(1.3)).norm(), 1e-12);
}

TEST(PlanMinSnapTest, AllWaypointsAtStartFromRestStaysStill) {
  const StartState start{{1, 2, 3}, Vec3::Zero(), Vec3::Zero()};
  const auto traj = PlanMinSnap(start, {start.position_W, start.position_W}, kPaperLimits);
  ASSERT_TRUE(traj.ok()) << traj.status();
  EXPECT_EQ(traj->NumSegments(), 1);
  EXPECT_NEAR(traj->Duration(), 0.1, 1e-12);
  EXPECT_EQ(traj->MaxSpeed(), 0.0);
  EXPECT_LE((traj->Position(0.05) - start.position_W).norm(), 1e-12);
}

TEST(PlanMinSnapTest, AllWaypointsAtStartWhileMovingBrakesAndReturns) {
  const StartState start{{1, 2, 10}, {2, 0, 0}, Vec3::Zero()};
  const auto traj = PlanMinSnap(start, {start.position_W}, kPaperLimits);
  ASSERT_TRUE(traj.ok()) << traj.status();
  EXPECT_LE((traj->Position(traj->Duration()) - start.position_W).norm(), 1e-9);
  const SampledMaxima m = DenseMaxima(*traj);
  EXPECT_LE(m.speed_m_s, 5.0 * (1 + 1e-6));
  EXPECT_LE(m.accel_m_s2, 3.0 * (1 + 1e-6));
}

TEST(PlanMinSnapInputTest, RejectsBadFieldsNamingThem) {
  const StartState ok_start{{0, 0, 10}, Vec3::Zero(), Vec3::Zero()};
  const Vec3 nan_v(std::nan(""), 0, 0);
  const auto expect_invalid = [](const absl::StatusOr<PolynomialTrajectory>& r,
                                 const std::string& field) {
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << field;
    EXPECT_THAT(r.status().message(), HasSubstr(field));
  };
  expect_invalid(PlanMinSnap(ok_start, {}, kPaperLimits), "waypoints_after_start_W");
  expect_invalid(PlanMinSnap(ok_start, {Vec3::Ones(), nan_v}, kPaperLimits),
                 "waypoints_after_start_W[1]");
  expect_invalid(PlanMinSnap({nan_v, Vec3::Zero(), Vec3::Zero()}, {Vec3::Ones()}, kPaperLimits),
                 "start.position_W");
  expect_invalid(PlanMinSnap({Vec3::Zero(), nan_v, Vec3::Zero()}, {Vec3::Ones()}, kPaperLimits),
                 "start.velocity_W_m_s");
  expect_invalid(PlanMinSnap({Vec3::Zero(), Vec3::Zero(), nan_v}, {Vec3::Ones()}, kPaperLimits),
                 "start.accel_W_m_s2");
  for (double bad : {0.0, -1.0, std::nan("")}) {
    expect_invalid(PlanMinSnap(ok_start, {Vec3::Ones()}, {.max_speed_m_s = bad}),
                   "limits.max_speed_m_s");
    expect_invalid(PlanMinSnap(ok_start, {Vec3::Ones()}, {.max_accel_m_s2 = bad}),
                   "limits.max_accel_m_s2");
  }
}

}  // namespace
}  // namespace oaipp
