// The UAV's state along a returned path, to replan from mid-flight.

#include "api/plan.h"
#include "gtest/gtest.h"

namespace oaipp::api {
namespace {

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
