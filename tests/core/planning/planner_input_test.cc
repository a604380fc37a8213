// Bad planner input gives a clear error naming the problem.
#include "core/planning/planners.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/planning/scenes.h"

namespace oaipp {
namespace {

using ::testing::HasSubstr;

class PlannerInputTest : public ::testing::TestWithParam<PlannerKind> {
 protected:
  static void SetUpTestSuite() { scene_ = new testing::Scene(testing::E1()); }
  absl::Status PlanFrom(const UavState& state, const PlanningContext* view = nullptr) {
    auto planner = MakePlanner({.kind = GetParam()});
    EXPECT_TRUE(planner.ok());
    return (*planner)->Plan(view ? *view : scene_->View(), state, absl::InfiniteFuture()).status();
  }
  static testing::Scene* scene_;
};
testing::Scene* PlannerInputTest::scene_ = nullptr;

TEST_P(PlannerInputTest, NanStateIsRefused) {
  UavState s = scene_->start;
  s.position_W.x() = NAN;
  const absl::Status st = PlanFrom(s);
  EXPECT_EQ(st.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(st.message(), HasSubstr("state.position_W"));
  s = scene_->start;
  s.velocity_W_m_s.z() = INFINITY;
  EXPECT_THAT(PlanFrom(s).message(), HasSubstr("state.velocity_W_m_s"));
}

TEST_P(PlannerInputTest, StartInsideAnObstacleIsRefused) {
  UavState s = scene_->start;
  s.position_W = Vec3(0, -1, 10);  // inside the building
  const absl::Status st = PlanFrom(s);
  EXPECT_EQ(st.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(st.message(), HasSubstr("inside an obstacle"));
  s.position_W = Vec3(5.3, -1, 10);  // 0.3 m from the wall: closer than r / 2
  EXPECT_EQ(PlanFrom(s).code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(PlanFrom(s).message(), HasSubstr("uav_radius_m"));
}

TEST_P(PlannerInputTest, OutsideTheVolumeOrOutOfBudgetIsRefused) {
  UavState s = scene_->start;
  s.position_W.z() = 40;
  EXPECT_EQ(PlanFrom(s).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(PlanFrom(s).message(), HasSubstr("outside the flight volume"));
  PlanningContext spent = scene_->View();
  spent.remaining_budget_s = 0;
  EXPECT_EQ(PlanFrom(scene_->start, &spent).code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(PlanFrom(scene_->start, &spent).message(), HasSubstr("remaining_budget_s"));
  s = scene_->start;
  s.mission_time_s = 10;
  const PlanningContext early = scene_->View(/*next_shot_mission_s=*/5);
  EXPECT_THAT(PlanFrom(s, &early).message(), HasSubstr("next_shot_mission_s"));
  s = scene_->start;
  s.velocity_W_m_s = Vec3(9, 0, 0);
  EXPECT_THAT(PlanFrom(s).message(), HasSubstr("max_speed"));
}

TEST_P(PlannerInputTest, MissingOrEmptyFieldIsRefused) {
  PlanningContext view = scene_->View();
  view.map = nullptr;
  EXPECT_THAT(PlanFrom(scene_->start, &view).message(), HasSubstr("mission.map"));
  // A field that lies entirely outside the flight volume.
  auto grid = FieldGrid::FromBounds({100, 100}, {130, 130}, 0.75);
  ASSERT_TRUE(grid.ok());
  auto far = GpMap::Create(*grid, GpParams::PaperPreset(0.75));
  ASSERT_TRUE(far.ok());
  view.map = &*far;
  EXPECT_THAT(PlanFrom(scene_->start, &view).message(), HasSubstr("outside the flight volume"));
}

INSTANTIATE_TEST_SUITE_P(AllPlanners, PlannerInputTest,
                         ::testing::Values(PlannerKind::kOaIpp, PlannerKind::kOaIppNonAdaptive,
                                           PlannerKind::kLawnmower, PlannerKind::kRandom));

TEST(PlannerConfigTest, BadConfigurationsAreRefused) {
  PlannerConfig c;
  c.oaipp.num_waypoints = 1;
  EXPECT_THAT(MakePlanner(c).status().message(), HasSubstr("num_waypoints"));
  c = {};
  c.oaipp.population = 2;
  EXPECT_THAT(MakePlanner(c).status().message(), HasSubstr("population"));
  c = {};
  c.common.limits.uav_radius_m = 0;
  EXPECT_THAT(MakePlanner(c).status().message(), HasSubstr("uav_radius_m"));
  c = {.kind = PlannerKind::kLawnmower};
  c.lawnmower.altitude_m = -1;
  EXPECT_THAT(MakePlanner(c).status().message(), HasSubstr("altitude_m"));
  EXPECT_FALSE(ParsePlannerKind("dijkstra").ok());
  EXPECT_EQ(*ParsePlannerKind("lawnmower"), PlannerKind::kLawnmower);
}

}  // namespace
}  // namespace oaipp
