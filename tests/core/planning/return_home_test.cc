// The way home and the planner that keeps one (core/planning/return_home.h,
// docs/method.md §2.7), checked with this file's own geometry and timing: a
// wall taller than the flight volume stands between the UAV and home, so
// the only ways round are past its ends. Every sample of a way home keeps
// the clearance from the wall (this file's box distance), stays in the
// volume and ends at home at rest; its route is no shorter than the
// shortest a path keeping the clearance can be, and no longer than one
// round corners a little farther out; its duration is no less than
// rest-to-rest legs at the limits allow.
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/planning/planners.h"
#include "core/planning/return_home.h"
#include "gtest/gtest.h"
#include "tests/core/planning/scenes.h"

namespace oaipp {
namespace {

using testing::FlightVolume;
using testing::MakeScene;
using testing::Scene;

constexpr double kWallHalfX = 1.0, kWallHalfY = 10.0;
constexpr double kClearance_m = 1.5;  // uav_radius_m 1 + tracking_error_m 0.5

// This file's distance from p to the wall [-1, 1] x [-10, 10] x [0, 40].
double ToWall(const Vec3& p) {
  const double dx = std::abs(p.x()) - kWallHalfX, dy = std::abs(p.y()) - kWallHalfY;
  const double dz = std::max(0.0 - p.z(), p.z() - 40.0);
  const double out = std::hypot(std::max(dx, 0.0), std::max(dy, 0.0), std::max(dz, 0.0));
  return out > 0.0 ? out : std::max({dx, dy, dz});
}

Scene WallScene() {
  return MakeScene(
      "wall",
      {{"wall", Box{.centre_W = {0, 0, 20}, .size_m = {2 * kWallHalfX, 2 * kWallHalfY, 40}}}},
      {-8, 0, 10});
}

PlannerLimits BodyLimits() {
  PlannerLimits limits;
  limits.uav_radius_m = 1.0;
  limits.tracking_error_m = 0.5;
  limits.obstacle_rule = PlannerLimits::ObstacleRule::kBody;
  return limits;
}

// Rest to rest over d at v_max, a_max on a trapezoid: no leg can be faster.
double FastestLeg(double d, double v, double a) {
  return d < v * v / a ? 2.0 * std::sqrt(d / a) : 2.0 * v / a + (d - v * v / a) / v;
}

void ExpectSafeAndHome(const PolynomialTrajectory& t, const Vec3& home) {
  const Aabb volume = FlightVolume();
  double closest = 1e9;
  for (double s = 0.0; s <= t.Duration() + 1e-9; s += 0.01) {
    const Vec3 p = t.Position(std::min(s, t.Duration()));
    closest = std::min(closest, ToWall(p));
    ASSERT_TRUE(volume.Contains(p, 1e-9)) << "t = " << s;
  }
  EXPECT_GE(closest, kClearance_m);
  EXPECT_LT((t.Position(t.Duration()) - home).norm(), 1e-6);
  EXPECT_LT(t.Velocity(t.Duration()).norm(), 1e-6);
}

TEST(ReturnHomeTest, TheWayHomeGoesRoundTheWallSafelyAndNoFasterThanTheLimitsAllow) {
  const Scene scene = WallScene();
  const PlannerLimits limits = BodyLimits();
  const Vec3 home(8, 0, 10);
  absl::StatusOr<WayHome> back = PlanWayHome(*scene.env, scene.start, home, limits);
  ASSERT_TRUE(back.ok()) << back.status();
  ExpectSafeAndHome(back->trajectory, home);
  EXPECT_LT((back->trajectory.Position(0) - scene.start.position_W).norm(), 1e-9);
  EXPECT_EQ(back->brake_s, 0.0);
  double length = 0.0, fastest = 0.0;
  for (std::size_t i = 1; i < back->route_W.size(); ++i) {
    const double d = (back->route_W[i] - back->route_W[i - 1]).norm();
    length += d;
    fastest += FastestLeg(d, limits.dynamics.max_speed_m_s, limits.dynamics.max_accel_m_s2);
  }
  // Any path keeping 1.5 m crosses x = 0 at |y| >= 11.5: at least the two
  // straight lines to there. Round corners 2 m out at (+-3, 12): 32 m.
  EXPECT_GE(length, 2.0 * std::hypot(8.0, kWallHalfY + kClearance_m));
  EXPECT_LE(length, 2.0 * std::hypot(5.0, 12.0) + 6.0);
  EXPECT_GE(back->trajectory.Duration(), fastest - 1e-9);
  EXPECT_LE(back->trajectory.Duration(), 3.0 * fastest);
}

TEST(ReturnHomeTest, AMovingUavBrakesFirstThenGoesHome) {
  const Scene scene = WallScene();
  UavState moving = scene.start;
  moving.velocity_W_m_s = Vec3(0, 3, 0);
  const Vec3 home(8, 0, 10);
  absl::StatusOr<WayHome> back = PlanWayHome(*scene.env, moving, home, BodyLimits());
  ASSERT_TRUE(back.ok()) << back.status();
  ExpectSafeAndHome(back->trajectory, home);
  EXPECT_LT((back->trajectory.Velocity(0) - moving.velocity_W_m_s).norm(), 1e-9);
  // Braking from 3 m/s at 3 m/s^2 takes at least 1 s.
  EXPECT_GE(back->brake_s, 1.0 - 1e-9);
  EXPECT_LT(back->trajectory.Velocity(back->brake_s).norm(), 1e-6);
}

TEST(ReturnHomeTest, NoWayHomeIsRefusedNamingHome) {
  // Home inside a courtyard walled up past the volume's top.
  std::vector<Obstacle> walls;
  for (const auto& [cx, cy, sx, sy] : std::vector<std::array<double, 4>>{
           {8, 12, 10, 2}, {8, 4, 10, 2}, {12, 8, 2, 10}, {4, 8, 2, 10}}) {
    walls.push_back(
        {absl::StrCat("w", walls.size()), Box{.centre_W = {cx, cy, 20}, .size_m = {sx, sy, 40}}});
  }
  const Scene scene = MakeScene("courtyard", walls, {-8, 0, 10});
  absl::StatusOr<WayHome> back = PlanWayHome(*scene.env, scene.start, {8, 8, 10}, BodyLimits());
  EXPECT_EQ(back.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(back.status().message().rfind("home: ", 0), 0u) << back.status();
}

TEST(ReturnHomeTest, APlanIsKeptOnlyWhereItsWayHomeFitsTheBudget) {
  const Scene scene = WallScene();
  PlannerConfig config{.kind = PlannerKind::kRandom};
  config.common.limits = BodyLimits();
  config.home = HomeConfig{.home_W = {8, 0, 10}, .reserve_s = 5.0, .landing_speed_m_s = 2.0};
  const double landing_s = 10.0 / 2.0;
  absl::StatusOr<std::unique_ptr<Planner>> planner = MakePlanner(config);
  ASSERT_TRUE(planner.ok()) << planner.status();
  PlanningContext context = scene.View();
  // Plenty left: a search plan, and the way home from its end.
  context.remaining_budget_s = 1000.0;
  absl::StatusOr<PlannedPath> path = (*planner)->Plan(context, scene.start, absl::InfiniteFuture());
  ASSERT_TRUE(path.ok()) << path.status();
  EXPECT_FALSE(path->returning_home);
  ASSERT_TRUE(path->way_home.has_value());
  ExpectSafeAndHome(*path->way_home, config.home->home_W);
  const Vec3 end = path->trajectory.Position(path->trajectory.Duration());
  EXPECT_LT((path->way_home->Position(0) - end).norm(), 1e-9);
  ASSERT_TRUE(path->remaining_after_return_s.has_value());
  EXPECT_NEAR(*path->remaining_after_return_s,
              1000.0 - path->trajectory.Duration() - path->way_home->Duration() - landing_s, 1e-9);
  // Less left than any way home needs: the plan is the way home now, and
  // it says the reserve is eaten into.
  context.remaining_budget_s = 12.0;
  path = (*planner)->Plan(context, scene.start, absl::InfiniteFuture());
  ASSERT_TRUE(path.ok()) << path.status();
  EXPECT_TRUE(path->returning_home);
  EXPECT_EQ(path->stats.stop_reason, "way_home");
  EXPECT_FALSE(path->way_home.has_value());
  ExpectSafeAndHome(path->trajectory, config.home->home_W);
  ASSERT_TRUE(path->remaining_after_return_s.has_value());
  EXPECT_NEAR(*path->remaining_after_return_s, 12.0 - path->trajectory.Duration() - landing_s,
              1e-9);
  EXPECT_LT(*path->remaining_after_return_s, config.home->reserve_s);
}

}  // namespace
}  // namespace oaipp
