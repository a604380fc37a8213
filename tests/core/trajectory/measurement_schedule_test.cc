#include "core/trajectory/measurement_schedule.h"

#include <cmath>
#include <random>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace oaipp {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

TEST(MeasurementScheduleTest, FirstShotAtCarriedTimeThenEveryPeriod) {
  // Trajectory over mission time [10, 30) s at 0.25 Hz, next shot due at 12 s:
  //   mission  10    12    16    20    24    28 | 32
  //   shots          x     x     x     x     x  | (next)
  const auto s = ScheduleMeasurements({.trajectory_start_mission_s = 10,
                                       .duration_s = 20,
                                       .rate_hz = 0.25,
                                       .next_shot_mission_s = 12});
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_THAT(s->times_s, ElementsAre(2, 6, 10, 14, 18));
  EXPECT_EQ(s->next_shot_mission_s, 32);
}

TEST(MeasurementScheduleTest, ShotExactlyAtTheEndBelongsToTheNextTrajectory) {
  const auto first = ScheduleMeasurements({.trajectory_start_mission_s = 0,
                                           .duration_s = 8,
                                           .rate_hz = 0.25,
                                           .next_shot_mission_s = 0});
  ASSERT_TRUE(first.ok());
  EXPECT_THAT(first->times_s, ElementsAre(0, 4));
  EXPECT_EQ(first->next_shot_mission_s, 8);
  const auto second = ScheduleMeasurements({.trajectory_start_mission_s = 8,
                                            .duration_s = 1,
                                            .rate_hz = 0.25,
                                            .next_shot_mission_s = first->next_shot_mission_s});
  ASSERT_TRUE(second.ok());
  EXPECT_THAT(second->times_s, ElementsAre(0));
}

TEST(MeasurementScheduleTest, ShotsMissedBeforeTheStartAreSkippedKeepingPhase) {
  const auto s = ScheduleMeasurements({.trajectory_start_mission_s = 9,
                                       .duration_s = 10,
                                       .rate_hz = 0.25,
                                       .next_shot_mission_s = 0});
  ASSERT_TRUE(s.ok());
  EXPECT_THAT(s->times_s, ElementsAre(3, 7));  // mission 12, 16
  EXPECT_EQ(s->next_shot_mission_s, 20);
}

// docs/method.md §4: the phase carries over across replans, so cutting a
// mission into consecutive trajectories must not move any shot.
TEST(MeasurementScheduleTest, ConsecutiveTrajectoriesGiveTheShotsOfOneLongTrajectory) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> piece(0.5, 25.0);
  for (double rate_hz : {0.15, 1.0, 3.7}) {
    const double start_s = 4.2, first_shot_s = 5.0;
    std::vector<double> pieces;
    double total_s = 0;
    for (int i = 0; i < 30; ++i) total_s += pieces.emplace_back(piece(rng));

    const auto whole = ScheduleMeasurements({.trajectory_start_mission_s = start_s,
                                             .duration_s = total_s,
                                             .rate_hz = rate_hz,
                                             .next_shot_mission_s = first_shot_s});
    ASSERT_TRUE(whole.ok());
    std::vector<double> split_mission_s;
    double t_s = start_s, next_s = first_shot_s;
    for (double d : pieces) {
      const auto s = ScheduleMeasurements({.trajectory_start_mission_s = t_s,
                                           .duration_s = d,
                                           .rate_hz = rate_hz,
                                           .next_shot_mission_s = next_s});
      ASSERT_TRUE(s.ok());
      for (double rel : s->times_s) {
        EXPECT_GE(rel, 0.0);
        EXPECT_LT(rel, d);
        split_mission_s.push_back(t_s + rel);
      }
      next_s = s->next_shot_mission_s;
      t_s += d;
    }
    ASSERT_EQ(split_mission_s.size(), whole->times_s.size()) << rate_hz;
    for (size_t i = 0; i < split_mission_s.size(); ++i) {
      EXPECT_NEAR(split_mission_s[i], start_s + whole->times_s[i], 1e-9) << i;
      EXPECT_NEAR(whole->times_s[i], first_shot_s - start_s + i / rate_hz, 1e-9) << i;
    }
    EXPECT_EQ(next_s, whole->next_shot_mission_s) << rate_hz;
  }
}

TEST(MeasurementScheduleTest, ZeroDurationHasNoShotsAndKeepsTheNextShot) {
  const auto s = ScheduleMeasurements(
      {.trajectory_start_mission_s = 3, .duration_s = 0, .rate_hz = 1, .next_shot_mission_s = 3});
  ASSERT_TRUE(s.ok());
  EXPECT_TRUE(s->times_s.empty());
  EXPECT_EQ(s->next_shot_mission_s, 3);
}

TEST(MeasurementScheduleInputTest, RejectsBadFieldsNamingThem) {
  const ShotWindow ok{
      .trajectory_start_mission_s = 0, .duration_s = 10, .rate_hz = 1, .next_shot_mission_s = 0};
  const auto expect_invalid = [](ShotWindow r, const std::string& field) {
    const auto s = ScheduleMeasurements(r);
    EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument) << field;
    EXPECT_THAT(s.status().message(), HasSubstr(field));
  };
  for (double bad : {0.0, -1.0, std::nan(""), double{INFINITY}}) {
    ShotWindow r = ok;
    r.rate_hz = bad;
    expect_invalid(r, "rate_hz");
  }
  ShotWindow r = ok;
  r.duration_s = -1;
  expect_invalid(r, "duration_s");
  r = ok;
  r.duration_s = std::nan("");
  expect_invalid(r, "duration_s");
  r = ok;
  r.trajectory_start_mission_s = INFINITY;
  expect_invalid(r, "trajectory_start_mission_s");
  r = ok;
  r.next_shot_mission_s = std::nan("");
  expect_invalid(r, "next_shot_mission_s");
  r = ok;
  r.rate_hz = 1e9;
  expect_invalid(r, "rate_hz");  // 10^10 shots
}

}  // namespace
}  // namespace oaipp
