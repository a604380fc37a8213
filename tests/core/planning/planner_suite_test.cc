// One suite that every planner passes, on every test world (docs/method.md §10):
// paths start at the UAV state, stay inside the flight volume, are
// collision-free under an independent exact check, respect the dynamic
// limits, and are identical for the same seed.
#include <map>
#include <memory>
#include <set>

#include "absl/strings/str_cat.h"
#include "core/planning/planners.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/planning/scenes.h"

namespace oaipp {
namespace {

using testing::Scene;

const Scene& CachedScene(const std::string& name) {
  static auto* scenes = new std::map<std::string, Scene>();
  auto it = scenes->find(name);
  if (it != scenes->end()) return it->second;
  Scene s;
  if (name == "E1") {
    s = testing::E1();
  } else if (name == "E4") {
    s = testing::NarrowPassage();
  } else {
    // e.g. "low5", "high15"
    const bool high = name.rfind("high", 0) == 0;
    const int count = std::stoi(name.substr(high ? 4 : 3));
    s = testing::RandomWorld(static_cast<unsigned>(count) * 7 + (high ? 1 : 0), count, high);
  }
  return scenes->emplace(name, std::move(s)).first->second;
}

PlannerConfig Config(PlannerKind kind) {
  PlannerConfig config{.kind = kind};
  config.common.seed = 11;
  config.oaipp.generations = 8;  // a short refinement keeps the suite quick
  if (kind == PlannerKind::kOaIppNonAdaptive) {
    // The trace objective costs up to n^3 per candidate at high altitude
    // (docs/method.md §6); a smaller search checks the same properties.
    config.oaipp.generations = 2;
    config.oaipp.greedy_candidates_per_layer = 3;
  }
  return config;
}

// Independent of the planner's own check: positions every <= 0.1 m of
// travel against the exact signed distance, speeds and accelerations every
// 5 ms against the limits.
void ExpectSafeAndFeasible(const PlannedPath& path, const Scene& scene, const UavState& start,
                           const PlannerLimits& limits) {
  const PolynomialTrajectory& traj = path.trajectory;
  EXPECT_TRUE(path.collision_free);
  EXPECT_LT((traj.Position(0) - start.position_W).norm(), 1e-9);
  EXPECT_LT((traj.Velocity(0) - start.velocity_W_m_s).norm(), 1e-6);
  EXPECT_LT((traj.Acceleration(0) - start.accel_W_m_s2).norm(), 1e-6);
  const double dt = 0.1 / limits.dynamics.max_speed_m_s;
  double worst_clearance = 1e9, top_speed = 0, top_accel = 0;
  for (double t = 0; t <= traj.Duration(); t += std::min(dt, 0.005)) {
    const Vec3 p = traj.Position(t);
    EXPECT_TRUE(scene.env->flight_volume().Contains(p, 1e-9)) << "t = " << t;
    worst_clearance = std::min(worst_clearance, scene.env->SignedDistance(p));
    top_speed = std::max(top_speed, traj.Velocity(t).norm());
    top_accel = std::max(top_accel, traj.Acceleration(t).norm());
  }
  EXPECT_GE(worst_clearance, 0.5 * limits.uav_radius_m);
  EXPECT_LE(top_speed, limits.dynamics.max_speed_m_s * (1 + 1e-6));
  EXPECT_LE(top_accel, limits.dynamics.max_accel_m_s2 * (1 + 1e-6));
  // Measurement poses lie on the path, in order, at the sensor rate.
  for (std::size_t i = 0; i < path.measurement_poses.size(); ++i) {
    const MeasurementPose& m = path.measurement_poses[i];
    EXPECT_LT((traj.Position(m.t_s) - m.position_W).norm(), 1e-9);
    if (i > 0) {
      EXPECT_NEAR(m.t_s - path.measurement_poses[i - 1].t_s, 1.0 / DownwardCamera{}.rate_hz, 1e-9);
    }
  }
}

// The sensor phase when the UAV leaves a path early, at `mission_time_s`.
double NextShotAfter(const PlannedPath& path, double mission_time_s) {
  for (const MeasurementPose& m : path.measurement_poses) {
    if (m.mission_time_s >= mission_time_s) return m.mission_time_s;
  }
  return path.next_shot_mission_s;
}

class PlannerSuiteTest : public ::testing::TestWithParam<std::tuple<PlannerKind, std::string>> {};

TEST_P(PlannerSuiteTest, SafeFeasibleAndReproducible) {
  const auto& [kind, world] = GetParam();
  const Scene& scene = CachedScene(world);
  const PlannerConfig config = Config(kind);
  auto first = MakePlanner(config);
  auto second = MakePlanner(config);
  ASSERT_TRUE(first.ok() && second.ok());

  UavState state = scene.start;
  // Two consecutive replans: the second starts where the first ended.
  double next_shot_mission_s = 0.0;
  for (int replan = 0; replan < 2; ++replan) {
    absl::StatusOr<PlannedPath> a =
        (*first)->Plan(scene.View(next_shot_mission_s), state, absl::InfiniteFuture());
    absl::StatusOr<PlannedPath> b =
        (*second)->Plan(scene.View(next_shot_mission_s), state, absl::InfiniteFuture());
    ASSERT_TRUE(a.ok()) << a.status();
    ASSERT_TRUE(b.ok()) << b.status();
    ExpectSafeAndFeasible(*a, scene, state, config.common.limits);
    // Same seed, same state: the very same path.
    ASSERT_EQ(a->control_waypoints_W.size(), b->control_waypoints_W.size());
    for (std::size_t i = 0; i < a->control_waypoints_W.size(); ++i) {
      EXPECT_EQ(a->control_waypoints_W[i], b->control_waypoints_W[i]);
    }
    EXPECT_EQ(a->objective, b->objective);
    // Replan where the path ends (docs/method.md §7.6).
    state = StateAlong(a->trajectory, a->trajectory.Duration(), state.mission_time_s);
    next_shot_mission_s = NextShotAfter(*a, state.mission_time_s);
  }
}

std::string Name(const ::testing::TestParamInfo<PlannerSuiteTest::ParamType>& info) {
  return absl::StrCat(PlannerKindName(std::get<0>(info.param)), "_", std::get<1>(info.param));
}

INSTANTIATE_TEST_SUITE_P(
    AllPlannersAllWorlds, PlannerSuiteTest,
    ::testing::Combine(::testing::Values(PlannerKind::kOaIpp, PlannerKind::kOaIppNonAdaptive,
                                         PlannerKind::kLawnmower, PlannerKind::kRandom),
                       ::testing::Values("E1", "E4", "low5", "low10", "low15", "high5", "high10",
                                         "high15")),
    Name);

// CMA-ES refinement never returns a path worse than its greedy start.
TEST(OaIppTest, RefinementNeverWorseThanGreedy) {
  const Scene& scene = CachedScene("E1");
  for (std::uint32_t seed = 1; seed <= 4; ++seed) {
    OaIppConfig config;
    config.generations = 10;
    OaIppPlanner planner(PlannerCommon{.seed = seed}, config);
    absl::StatusOr<PlannedPath> path =
        planner.Plan(scene.View(), scene.start, absl::InfiniteFuture());
    ASSERT_TRUE(path.ok()) << path.status();
    EXPECT_GE(path->objective, path->stats.initial_objective) << "seed " << seed;
    EXPECT_EQ(path->stats.generations, 10);
    EXPECT_EQ(path->stats.stop_reason, "evaluation_budget");
    EXPECT_EQ(path->control_waypoints_W.size(), 3u);
  }
}

// The stall rule only ends the search early: the path is checked like any
// other and is never worse than its greedy start; with the rule off (the
// default) every generation runs.
TEST(OaIppTest, AStalledSearchStopsEarlyWithASafePath) {
  const Scene& scene = CachedScene("E1");
  OaIppConfig full_config;
  OaIppConfig stall_config;
  stall_config.stall_generations = 3;
  stall_config.stall_tolerance = 0.05;
  int stalled = 0;
  for (std::uint32_t seed = 1; seed <= 4; ++seed) {
    OaIppPlanner full(PlannerCommon{.seed = seed}, full_config);
    OaIppPlanner early(PlannerCommon{.seed = seed}, stall_config);
    absl::StatusOr<PlannedPath> a = full.Plan(scene.View(), scene.start, absl::InfiniteFuture());
    absl::StatusOr<PlannedPath> b = early.Plan(scene.View(), scene.start, absl::InfiniteFuture());
    ASSERT_TRUE(a.ok()) << a.status();
    ASSERT_TRUE(b.ok()) << b.status();
    EXPECT_EQ(a->stats.generations, 45);
    EXPECT_EQ(a->stats.stop_reason, "evaluation_budget");
    ExpectSafeAndFeasible(*b, scene, scene.start, PlannerLimits{});
    EXPECT_GE(b->objective, b->stats.initial_objective) << "seed " << seed;
    if (b->stats.stop_reason == "stalled") {
      ++stalled;
      EXPECT_LT(b->stats.generations, 45);
      EXPECT_GE(b->stats.generations, 3);
      EXPECT_LT(b->stats.evaluations, a->stats.evaluations);
    }
  }
  // A 5 % improvement every 3 generations is more than most plans keep up.
  EXPECT_GE(stalled, 1);
}

TEST(OaIppTest, DeadlineGivesAnAnytimeResult) {
  const Scene& scene = CachedScene("E1");
  OaIppPlanner planner(PlannerCommon{}, OaIppConfig{});
  // A deadline already past: the greedy start is still checked and returned.
  absl::StatusOr<PlannedPath> path = planner.Plan(scene.View(), scene.start, absl::InfinitePast());
  ASSERT_TRUE(path.ok()) << path.status();
  EXPECT_EQ(path->stats.stop_reason, "deadline");
  EXPECT_EQ(path->stats.generations, 0);
  // The greedy start stopped after its first reachable viewpoint.
  EXPECT_EQ(path->control_waypoints_W.size(), 2u);
}

// At full speed and still accelerating forwards no minimum-snap path meets
// the speed limit: OA-IPP gives up after the greedy start and one
// generation instead of scoring all 45, and the stop-first wrapper brakes
// and plans from rest.
TEST(OaIppTest, GivesUpEarlyWhereNoTrajectoryMeetsTheLimits) {
  const Scene& scene = CachedScene("E1");
  UavState state = scene.start;
  state.position_W = Vec3(-12.0, 0.0, 12.0);
  state.velocity_W_m_s = Vec3(4.5, 0.0, 0.0);
  state.accel_W_m_s2 = Vec3(3.0, 0.0, 0.0);
  const OaIppConfig config;
  OaIppPlanner planner(PlannerCommon{}, config);
  absl::StatusOr<PlannedPath> direct = planner.Plan(scene.View(), state, absl::InfiniteFuture());
  ASSERT_EQ(direct.status().code(), absl::StatusCode::kFailedPrecondition) << direct.status();
  EXPECT_THAT(std::string(direct.status().message()),
              ::testing::HasSubstr(absl::StrCat("none of the first ", config.population + 1,
                                                " candidate paths meets the speed")));
  auto wrapped = MakePlanner(PlannerConfig{});
  ASSERT_TRUE(wrapped.ok());
  absl::StatusOr<PlannedPath> path = (*wrapped)->Plan(scene.View(), state, absl::InfiniteFuture());
  ASSERT_TRUE(path.ok()) << path.status();
  EXPECT_GT(path->stats.stop_first_s, 0.0);
  EXPECT_LE(path->trajectory.MaxSpeed(), 5.0 * (1 + 1e-6));
}

TEST(LawnmowerTest, PatternCoversTheFieldAtTenMetres) {
  const Scene& scene = CachedScene("E1");
  const Aabb box = scene.env->flight_volume().Inflated(-0.5);
  const std::vector<Vec3> pattern =
      LawnmowerPlanner::Pattern(scene.map->grid(), box, DownwardCamera{}, 10.0);
  // Footprint at 10 m: 8.28 x 11.55 m; 30 m / 11.55 m -> 3 lanes, 10 m apart.
  ASSERT_EQ(pattern.size(), 6u);
  EXPECT_NEAR(pattern[0].y(), -10.0, 1e-9);
  EXPECT_NEAR(pattern[2].y(), 0.0, 1e-9);
  EXPECT_NEAR(pattern[0].x(), -15 + 8.284271 / 2, 1e-6);
  for (const Vec3& p : pattern) EXPECT_DOUBLE_EQ(p.z(), 10.0);
}

// Corner bit 0 starts at the highest-y lane, bit 1 flies the first lane
// from high x; the seeded default draws every corner over a few seeds.
TEST(LawnmowerTest, StartCorners) {
  const Scene& scene = CachedScene("E1");
  const Aabb box = scene.env->flight_volume().Inflated(-0.5);
  const double x_lo = -15 + 8.284271 / 2, x_hi = 15 - 8.284271 / 2;
  const struct {
    int corner;
    double first_x, first_y, last_y;
  } cases[] = {{0, x_lo, -10, 10}, {1, x_lo, 10, -10}, {2, x_hi, -10, 10}, {3, x_hi, 10, -10}};
  for (const auto& c : cases) {
    const std::vector<Vec3> pattern =
        LawnmowerPlanner::Pattern(scene.map->grid(), box, DownwardCamera{}, 10.0, c.corner);
    ASSERT_EQ(pattern.size(), 6u) << c.corner;
    EXPECT_NEAR(pattern.front().x(), c.first_x, 1e-6) << c.corner;
    EXPECT_NEAR(pattern.front().y(), c.first_y, 1e-9) << c.corner;
    EXPECT_NEAR(pattern[1].x(), c.first_x == x_lo ? x_hi : x_lo, 1e-6) << c.corner;
    EXPECT_NEAR(pattern.back().y(), c.last_y, 1e-9) << c.corner;
  }
  std::set<std::pair<double, double>> first_points;
  for (std::uint32_t seed = 1; seed <= 16; ++seed) {
    LawnmowerPlanner planner(PlannerCommon{.seed = seed}, LawnmowerConfig{});
    absl::StatusOr<PlannedPath> path =
        planner.Plan(scene.View(), scene.start, absl::InfiniteFuture());
    ASSERT_TRUE(path.ok()) << path.status();
    const Vec3 first = path->control_waypoints_W.back();
    first_points.insert({std::round(first.x()), std::round(first.y())});
  }
  EXPECT_GE(first_points.size(), 3u);
  LawnmowerConfig bad;
  bad.start_corner = 4;
  EXPECT_NE(bad.Validate().message().find("lawnmower.start_corner"), std::string::npos);
}

TEST(LawnmowerTest, DetoursAroundTheBuildingAndKeepsItsPlace) {
  const Scene& scene = CachedScene("E1");
  LawnmowerPlanner planner(PlannerCommon{}, LawnmowerConfig{});
  UavState state = scene.start;
  double next_shot_mission_s = 0.0;
  for (int replan = 0; replan < 4; ++replan) {
    absl::StatusOr<PlannedPath> path =
        planner.Plan(scene.View(next_shot_mission_s), state, absl::InfiniteFuture());
    ASSERT_TRUE(path.ok()) << path.status();
    ExpectSafeAndFeasible(*path, scene, state, PlannerLimits{});
    state.position_W = path->trajectory.Position(path->trajectory.Duration());
    state.mission_time_s += path->trajectory.Duration();
    next_shot_mission_s = path->next_shot_mission_s;
  }
  EXPECT_EQ(planner.next_index(), 8);  // two pattern points per replan
}

}  // namespace
}  // namespace oaipp
