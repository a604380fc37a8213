// The simulated flight: distance flown, steps closer than r_uav / 2 to the
// E1 building under the exact geometry, the trace, and the step callback.
#include "sim/flight.h"

#include <cmath>

#include "gtest/gtest.h"
#include "sim/scenario.h"

namespace oaipp::sim {
namespace {

// x(t) = x0 + v t along y = -1, z = 7: straight through the E1 building
// (x in [-5, 5], y in [-3, 1], 26 m tall).
PolynomialTrajectory StraightLine(double x0, double v, double duration_s) {
  PolynomialTrajectory::SegmentCoefficients c = PolynomialTrajectory::SegmentCoefficients::Zero();
  c(0, 0) = x0;
  c(1, 0) = v;
  c(0, 1) = -1.0;
  c(0, 2) = 7.0;
  return *PolynomialTrajectory::FromCoefficients({duration_s}, {c});
}

Simulation E1Simulation() {
  absl::StatusOr<v1::Scenario> scenario = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e1.json");
  EXPECT_TRUE(scenario.ok()) << scenario.status();
  absl::StatusOr<Simulation> simulation = Simulation::Create(*scenario);
  EXPECT_TRUE(simulation.ok()) << simulation.status();
  return *std::move(simulation);
}

TEST(FlightTest, CountsTheStepsWithinHalfTheUavRadiusOfTheBuilding) {
  const Simulation simulation = E1Simulation();
  ASSERT_EQ(simulation.config().planner.common.limits.uav_radius_m, 1.0);
  // From x = -10.01 at 1 m/s for 20.02 s: step k is at x = -10.01 + 0.02 k
  // and collides when |x| < 5 + 0.5, i.e. for k = 226 .. 775: 550 steps.
  Flight flight(simulation, Vec3(-10.01, -1, 7));
  int steps = 0;
  double last_t = -1.0;
  const absl::StatusOr<double> stopped =
      flight.Fly(StraightLine(-10.01, 1.0, 20.02), 20.02, [&](double t_s) {
        ++steps;
        last_t = t_s;
        return true;
      });
  ASSERT_TRUE(stopped.ok());
  EXPECT_EQ(*stopped, 20.02);
  // t = 0, 0.02, ..., 20.02; the times are accumulated, so round-off may
  // leave one more, tiny, step before the end.
  EXPECT_GE(steps, 1002);
  EXPECT_LE(steps, 1003);
  EXPECT_EQ(last_t, 20.02);
  EXPECT_EQ(flight.collisions(), 550);
  EXPECT_NEAR(flight.path_length_m(), 20.02, 1e-9);
  // The trace starts at the start and keeps a point once the UAV is more
  // than 0.5 m from the last one kept, so neighbours lie 0.5 .. 0.52 m apart.
  const std::vector<Vec3>& trace = flight.trace_W();
  EXPECT_EQ(trace.front(), Vec3(-10.01, -1, 7));
  ASSERT_GE(trace.size(), 38u);
  for (std::size_t i = 1; i < trace.size(); ++i) {
    const double gap = (trace[i] - trace[i - 1]).norm();
    EXPECT_GT(gap, 0.5);
    EXPECT_LE(gap, 0.52 + 1e-9);
  }
}

// A team member with a wider radius and a narrower camera of its own
// (spec.team[i].flight and .sensor): its flight counts the steps within its
// own r_uav / 2, and its images are its camera's.
TEST(FlightTest, AMemberFliesWithItsOwnRadiusAndCamera) {
  absl::StatusOr<v1::Scenario> scenario = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e1.json");
  ASSERT_TRUE(scenario.ok()) << scenario.status();
  v1::MissionSpec& spec = *scenario->mutable_mission();
  for (const char* id : {"a", "wide"}) {
    v1::TeamMember& m = *spec.add_team();
    m.set_uav_id(id);
    m.mutable_start()->mutable_position_m()->set_x(id[0] == 'a' ? -10 : 10);
    m.mutable_start()->mutable_position_m()->set_y(10);
    m.mutable_start()->mutable_position_m()->set_z(10);
  }
  spec.mutable_team(1)->mutable_flight()->set_uav_radius_m(3.0);
  spec.mutable_team(1)->mutable_sensor()->set_fov_x_deg(30);
  absl::StatusOr<Simulation> simulation = Simulation::Create(*scenario);
  ASSERT_TRUE(simulation.ok()) << simulation.status();
  // Steps at x = -10.01 + 0.02 k collide when |x| < 5 + 1.5: k = 176 .. 825.
  Flight wide(*simulation, Vec3(-10.01, -1, 7), "wide");
  ASSERT_TRUE(wide.Fly(StraightLine(-10.01, 1.0, 20.02), 20.02, [](double) { return true; }).ok());
  EXPECT_EQ(wide.collisions(), 650);
  Flight a(*simulation, Vec3(-10.01, -1, 7), "a");
  ASSERT_TRUE(a.Fly(StraightLine(-10.01, 1.0, 20.02), 20.02, [](double) { return true; }).ok());
  EXPECT_EQ(a.collisions(), 550);
  // The same image size, a longer focal length: fx = (w / 2) / tan(fov_x / 2).
  const CameraIntrinsics& own = simulation->intrinsics("wide");
  const CameraIntrinsics& mission = simulation->intrinsics("a");
  EXPECT_EQ(own.width_px, mission.width_px);
  EXPECT_NEAR(own.fx_px, 0.5 * own.width_px / std::tan(15.0 * M_PI / 180.0), 1e-9);
  EXPECT_NEAR(mission.fx_px, simulation->intrinsics().fx_px, 1e-12);
  EXPECT_GT(own.fx_px, mission.fx_px);
  // The labels of one image span that camera's footprint: narrower for the
  // member, by tan(15 deg) / tan(22.5 deg) across x.
  const Vec3 high(0, 10, 12);
  const absl::StatusOr<CellLabels> narrow = simulation->Labels(high, {}, "wide");
  const absl::StatusOr<CellLabels> usual = simulation->Labels(high, {}, "a");
  ASSERT_TRUE(narrow.ok() && usual.ok());
  const double ratio = static_cast<double>(narrow->cells.size()) / usual->cells.size();
  EXPECT_NEAR(ratio, std::tan(15.0 * M_PI / 180.0) / std::tan(22.5 * M_PI / 180.0), 0.1);
}

TEST(FlightTest, StopsAtTheFirstErrorOfTheCallback) {
  const Simulation simulation = E1Simulation();
  Flight flight(simulation, Vec3(10, -1, 7));
  int steps = 0;
  const absl::StatusOr<double> stopped =
      flight.Fly(StraightLine(10, -1.0, 2.0), 2.0, [&](double t_s) -> absl::StatusOr<bool> {
        ++steps;
        if (t_s >= 0.1 - 1e-12) return absl::UnavailableError("server gone");
        return true;
      });
  EXPECT_EQ(stopped.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(steps, 6);  // t = 0 .. 0.1
  EXPECT_NEAR(flight.path_length_m(), 0.1, 1e-9);
  EXPECT_EQ(flight.collisions(), 0);
}

TEST(FlightTest, StopsWhereTheCallbackSaysNotToFlyOn) {
  const Simulation simulation = E1Simulation();
  Flight flight(simulation, Vec3(10, -1, 7));
  int steps = 0;
  const absl::StatusOr<double> stopped =
      flight.Fly(StraightLine(10, -1.0, 2.0), 2.0, [&](double t_s) {
        ++steps;
        return t_s < 0.5 - 1e-12;
      });
  ASSERT_TRUE(stopped.ok());
  EXPECT_NEAR(*stopped, 0.5, 1e-12);
  EXPECT_EQ(steps, 26);  // t = 0 .. 0.5
  EXPECT_NEAR(flight.path_length_m(), 0.5, 1e-9);
}

}  // namespace
}  // namespace oaipp::sim
