// The client-side helpers for a plan the server cut short under load: when
// to leave it, and the moving state to ask again from. The mission runner
// and server_load take the shot at the point left as the next path's first.
#include <cmath>

#include "api/plan.h"
#include "gtest/gtest.h"

namespace oaipp::api {
namespace {

// A response with shots at the given times (s into the path) and the given
// search share and stop reason.
v1::PlanPathResponse Response(std::initializer_list<double> shots, double search_fraction,
                              const char* stop_reason) {
  v1::PlanPathResponse r;
  for (double t : shots) r.add_measurement_poses()->set_t_s(t);
  r.mutable_stats()->set_search_fraction(search_fraction);
  r.mutable_stats()->set_stop_reason(stop_reason);
  return r;
}

TEST(PlanTest, AWholePlanIsFlownToTheEnd) {
  const v1::PlanPathResponse whole = Response({0.0, 6.5, 13.0}, 1.0, "evaluation_budget");
  EXPECT_FALSE(PlanWasCutByLoad(whole, false));
  EXPECT_EQ(FlightBeforeReplan(whole, false, 20.0), 20.0);
  EXPECT_EQ(FlightBeforeReplan(whole, false, 20.0, 5.0), 20.0);
}

TEST(PlanTest, APlanCutByLoadIsLeftAtItsFirstShotAfterTheStart) {
  // Shed by the queue's length.
  const v1::PlanPathResponse shed = Response({0.0, 6.5, 13.0}, 0.25, "evaluation_budget");
  EXPECT_TRUE(PlanWasCutByLoad(shed, false));
  EXPECT_TRUE(PlanWasCutByLoad(shed, true));              // a share below 1 is always the server's
  EXPECT_EQ(FlightBeforeReplan(shed, false, 20.0), 6.5);  // not the shot at 0
  // Ended by the server's latency bound.
  const v1::PlanPathResponse late = Response({0.0, 6.5, 13.0}, 1.0, "deadline");
  EXPECT_TRUE(PlanWasCutByLoad(late, false));
  EXPECT_EQ(FlightBeforeReplan(late, false, 20.0), 6.5);
  // A fleet's own point: the first shot at or after it.
  EXPECT_EQ(FlightBeforeReplan(late, false, 20.0, 6.5), 6.5);
  EXPECT_EQ(FlightBeforeReplan(late, false, 20.0, 7.0), 13.0);
  // No shot left before the flight ends: flown as it would be.
  EXPECT_EQ(FlightBeforeReplan(late, false, 20.0, 14.0), 20.0);
  EXPECT_EQ(FlightBeforeReplan(late, false, 13.0, 7.0), 13.0);
  EXPECT_EQ(FlightBeforeReplan(Response({}, 0.5, "deadline"), false, 20.0), 20.0);
  // The start shot a few ulps after 0 (the time the plan was asked for) is
  // not a place to leave: that would not move the UAV.
  EXPECT_EQ(FlightBeforeReplan(Response({1e-14, 6.5}, 0.5, "deadline"), false, 20.0), 6.5);
}

TEST(PlanTest, AnUnsetSearchShareIsAWholeSearch) {
  // A server from before stats.search_fraction leaves it 0; it never shed.
  const v1::PlanPathResponse old = Response({0.0, 6.5}, 0.0, "evaluation_budget");
  EXPECT_FALSE(PlanWasCutByLoad(old, false));
  EXPECT_EQ(FlightBeforeReplan(old, false, 20.0), 20.0);
}

TEST(PlanTest, ADeadlineOfTheClientsOwnBudgetIsNotLoad) {
  const v1::PlanPathResponse late = Response({0.0, 6.5, 13.0}, 1.0, "deadline");
  EXPECT_FALSE(PlanWasCutByLoad(late, true));
  EXPECT_EQ(FlightBeforeReplan(late, true, 20.0), 20.0);
}

TEST(PlanTest, TheStateAlongAPathIsThePolynomialsValueAndDerivatives) {
  // One 4 s segment: x = 1 + 2t + 3t^2, y = t^3, z = 5 - t. At t = 2:
  // x 17, 14, 6; y 8, 12, 12; z 3, -1, 0.
  v1::Trajectory t;
  t.set_duration_s(4.0);
  v1::PolynomialSegment& s = *t.add_segments();
  s.set_duration_s(4.0);
  for (double c : {1.0, 2.0, 3.0}) s.add_x_coefficients(c);
  for (double c : {0.0, 0.0, 0.0, 1.0}) s.add_y_coefficients(c);
  for (double c : {5.0, -1.0}) s.add_z_coefficients(c);
  const absl::StatusOr<PolynomialTrajectory> trajectory = TrajectoryFromProto(t);
  ASSERT_TRUE(trajectory.ok()) << trajectory.status();
  const v1::UavState state = StateAlongPath(*trajectory, 2.0, 30.0);
  EXPECT_NEAR(state.position_m().x(), 17.0, 1e-12);
  EXPECT_NEAR(state.position_m().y(), 8.0, 1e-12);
  EXPECT_NEAR(state.position_m().z(), 3.0, 1e-12);
  EXPECT_NEAR(state.velocity_m_s().x(), 14.0, 1e-12);
  EXPECT_NEAR(state.velocity_m_s().y(), 12.0, 1e-12);
  EXPECT_NEAR(state.velocity_m_s().z(), -1.0, 1e-12);
  EXPECT_NEAR(state.acceleration_m_s2().x(), 6.0, 1e-12);
  EXPECT_NEAR(state.acceleration_m_s2().y(), 12.0, 1e-12);
  EXPECT_NEAR(state.acceleration_m_s2().z(), 0.0, 1e-12);
  EXPECT_EQ(state.mission_time_s(), 32.0);
}

}  // namespace
}  // namespace oaipp::api
