// A team whose members fly with their own cameras, detectors and flight
// limits (spec.team[i].sensor and .flight, docs/teams.md), through the
// service in process: a member's measurement is fused exactly as a
// one-UAV mission with that member's sensor fuses it, a member's plan keeps
// its own speed and acceleration (by this file's own differentiation of the
// returned polynomials) and shoots at its own rate, and the mission's spec
// answers every member's settings filled in.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/server/service_fixture.h"
#include "tests/server/team_fixture.h"

namespace oaipp::server {
namespace {

using testing::At;
using testing::CreateTeam;
using testing::InProcessService;
using testing::PlanFor;
using testing::Point;
using testing::TeamSpec;

const std::vector<Point> kStarts = {{-8, 8, 8}, {8, 8, 8}};

// Team a, b at kStarts; b has a narrower camera, a noisier detector, a
// faster shutter and a slower, gentler flight than the mission's.
v1::MissionSpec MixedTeam() {
  v1::MissionSpec spec = TeamSpec(kStarts);
  v1::TeamMember& b = *spec.mutable_team(1);
  b.mutable_sensor()->set_fov_x_deg(30);
  b.mutable_sensor()->set_fov_y_deg(40);
  b.mutable_sensor()->set_noise_a_var(4);
  b.mutable_sensor()->set_rate_hz(0.5);
  b.mutable_flight()->set_max_speed_m_s(1.5);
  b.mutable_flight()->set_max_accel_m_s2(1);
  return spec;
}

// The same world flown by one UAV at `start` with `sensor` (unset fields:
// the mission's).
v1::MissionSpec Alone(const Point& start, const v1::SensorSpec& sensor) {
  v1::MissionSpec spec = TeamSpec({});
  spec.clear_min_separation_m();
  *spec.mutable_start() = At(start, 0);
  spec.mutable_sensor()->MergeFrom(sensor);
  return spec;
}

// One image of a person under the camera at `at`, sent as detections in the
// mission's default image (no intrinsics: the server takes the UAV's own
// camera's).
v1::AddMeasurementResponse Shoot(v1::MissionService::Stub& stub, const std::string& mission,
                                 const std::string& uav_id, const Point& at) {
  v1::AddMeasurementRequest request;
  request.set_name("missions/" + mission);
  request.set_uav_id(uav_id);
  request.set_request_id("shot-" + uav_id);
  request.set_mission_time_s(1.0);
  request.mutable_camera_position_m()->set_x(at.x);
  request.mutable_camera_position_m()->set_y(at.y);
  request.mutable_camera_position_m()->set_z(at.z);
  testing::AddPersonUnderCamera(request);
  grpc::ClientContext context;
  v1::AddMeasurementResponse response;
  const grpc::Status status = stub.AddMeasurement(&context, request, &response);
  EXPECT_TRUE(status.ok()) << mission << ": " << status.error_message();
  return response;
}

v1::GetMapResponse MapOf(v1::MissionService::Stub& stub, const std::string& mission) {
  grpc::ClientContext context;
  v1::GetMapRequest request;
  request.set_name("missions/" + mission);
  request.set_include_cells(true);
  v1::GetMapResponse map;
  const grpc::Status status = stub.GetMap(&context, request, &map);
  EXPECT_TRUE(status.ok()) << mission << ": " << status.error_message();
  return map;
}

// The largest difference of two maps' means and variances, cell by cell.
double MaxDifference(const v1::GetMapResponse& a, const v1::GetMapResponse& b) {
  EXPECT_EQ(a.mean_size(), b.mean_size());
  double worst = 0.0;
  for (int i = 0; i < std::min(a.mean_size(), b.mean_size()); ++i) {
    worst = std::max(worst, std::abs(a.mean(i) - b.mean(i)));
    worst = std::max(worst, std::abs(a.variance(i) - b.variance(i)));
  }
  return worst;
}

TEST(TeamMemberTest, EachMembersShotIsFusedWithItsOwnCameraAndNoise) {
  InProcessService service(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600});
  v1::Mission out;
  ASSERT_TRUE(CreateTeam(service.stub(), "team-b", MixedTeam(), &out).ok());
  ASSERT_TRUE(CreateTeam(service.stub(), "team-a", MixedTeam(), &out).ok());
  ASSERT_TRUE(
      CreateTeam(service.stub(), "as-b", Alone(kStarts[1], MixedTeam().team(1).sensor()), &out)
          .ok());
  ASSERT_TRUE(CreateTeam(service.stub(), "as-a", Alone(kStarts[0], {}), &out).ok());

  // b's shot in the team fuses as a one-UAV mission with b's sensor fuses
  // it, and a's as one with the mission's sensor: the whole maps agree.
  const Point over_b{8, 8, 10};
  const v1::AddMeasurementResponse team_b = Shoot(service.stub(), "team-b", "b", over_b);
  const v1::AddMeasurementResponse alone_b = Shoot(service.stub(), "as-b", "", over_b);
  EXPECT_EQ(team_b.cells_fused(), alone_b.cells_fused());
  EXPECT_LT(MaxDifference(MapOf(service.stub(), "team-b"), MapOf(service.stub(), "as-b")), 1e-12);
  const v1::AddMeasurementResponse team_a = Shoot(service.stub(), "team-a", "a", over_b);
  const v1::AddMeasurementResponse alone_a = Shoot(service.stub(), "as-a", "", over_b);
  EXPECT_EQ(team_a.cells_fused(), alone_a.cells_fused());
  EXPECT_LT(MaxDifference(MapOf(service.stub(), "team-a"), MapOf(service.stub(), "as-a")), 1e-12);

  // And the two differ: b's narrower camera sees fewer cells, its noisier
  // detector moves the cell under the person less.
  EXPECT_LT(team_b.cells_fused(), team_a.cells_fused());
  const v1::GetMapResponse b_map = MapOf(service.stub(), "team-b");
  const v1::GetMapResponse a_map = MapOf(service.stub(), "team-a");
  const int col = static_cast<int>((over_b.x - b_map.x_min_m()) / b_map.resolution_m());
  const int row = static_cast<int>((over_b.y - b_map.y_min_m()) / b_map.resolution_m());
  const int under = row * b_map.nx() + col;
  EXPECT_GT(a_map.mean(under), 0.5);
  EXPECT_LT(b_map.mean(under), a_map.mean(under) - 1e-3);
  EXPECT_GT(b_map.variance(under), a_map.variance(under));
}

// The largest speed and acceleration of a returned path, from its segments'
// polynomials differentiated here.
struct Peaks {
  double speed = 0.0;
  double accel = 0.0;
};

Peaks PeaksOf(const v1::PlanPathResponse& path) {
  Peaks peaks;
  for (const v1::PolynomialSegment& seg : path.trajectory().segments()) {
    const auto derivative = [](const google::protobuf::RepeatedField<double>& c, int order,
                               double tau) {
      double v = 0.0;
      for (int i = c.size() - 1; i >= order; --i) {
        double factor = 1.0;
        for (int k = 0; k < order; ++k) factor *= i - k;
        v = v * tau + factor * c.Get(i);
      }
      return v;
    };
    for (double tau = 0.0; tau <= seg.duration_s(); tau += 0.01) {
      const double vx = derivative(seg.x_coefficients(), 1, tau);
      const double vy = derivative(seg.y_coefficients(), 1, tau);
      const double vz = derivative(seg.z_coefficients(), 1, tau);
      const double ax = derivative(seg.x_coefficients(), 2, tau);
      const double ay = derivative(seg.y_coefficients(), 2, tau);
      const double az = derivative(seg.z_coefficients(), 2, tau);
      peaks.speed = std::max(peaks.speed, std::hypot(vx, vy, vz));
      peaks.accel = std::max(peaks.accel, std::hypot(ax, ay, az));
    }
  }
  return peaks;
}

TEST(TeamMemberTest, EachMemberPlansWithinItsOwnLimitsAtItsOwnRate) {
  InProcessService service(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600});
  v1::MissionSpec spec = MixedTeam();
  spec.mutable_planner()->set_kind(v1::PLANNER_KIND_RANDOM);
  v1::Mission team;
  ASSERT_TRUE(CreateTeam(service.stub(), "team", spec, &team).ok());
  v1::PlanPathResponse a, b;
  ASSERT_TRUE(PlanFor(service.stub(), "team", "a", At(kStarts[0], 0), "pa", &a).ok());
  const grpc::Status planned = PlanFor(service.stub(), "team", "b", At(kStarts[1], 0), "pb", &b);
  ASSERT_TRUE(planned.ok()) << planned.error_message();

  const Peaks pa = PeaksOf(a), pb = PeaksOf(b);
  EXPECT_LE(pb.speed, 1.5 * (1 + 1e-6));
  EXPECT_LE(pb.accel, 1.0 * (1 + 1e-6));
  // a flies as the mission allows, faster than b may.
  EXPECT_GT(pa.speed, 1.5 * 1.2);
  EXPECT_LE(pa.speed, 5.0 * (1 + 1e-6));
  // b's camera fires every 2 s, a's every 1 / 0.15 s (the mission's).
  ASSERT_GE(b.measurement_poses_size(), 3);
  for (int i = 1; i < b.measurement_poses_size(); ++i) {
    EXPECT_NEAR(
        b.measurement_poses(i).mission_time_s() - b.measurement_poses(i - 1).mission_time_s(), 2.0,
        1e-9);
  }
  ASSERT_GE(a.measurement_poses_size(), 2);
  EXPECT_NEAR(a.measurement_poses(1).mission_time_s() - a.measurement_poses(0).mission_time_s(),
              1.0 / 0.15, 1e-9);
}

// A state beyond a member's own limits, within the mission's, is refused
// naming the member's field.
TEST(TeamMemberTest, APlanBeyondAMembersOwnLimitsNamesItsField) {
  InProcessService service(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600});
  v1::Mission team;
  ASSERT_TRUE(CreateTeam(service.stub(), "team", MixedTeam(), &team).ok());
  v1::UavState fast = At(kStarts[1], 0);
  fast.mutable_velocity_m_s()->set_x(3);  // the mission allows 5 m/s, b 1.5
  v1::PlanPathResponse path;
  const grpc::Status status = PlanFor(service.stub(), "team", "b", fast, "pb", &path);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), ::testing::HasSubstr("spec.team[1].flight.max_speed_m_s"));
  fast = At(kStarts[0], 0);
  fast.mutable_velocity_m_s()->set_x(3);
  EXPECT_TRUE(PlanFor(service.stub(), "team", "a", fast, "pa", &path).ok());
}

TEST(TeamMemberTest, TheSpecAnswersEveryMembersSettingsFilledIn) {
  InProcessService service(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600});
  v1::MissionSpec spec = MixedTeam();
  spec.mutable_sensor()->set_rate_hz(0.2);  // a inherits it, b keeps its own
  v1::Mission team;
  ASSERT_TRUE(CreateTeam(service.stub(), "team", spec, &team).ok());
  const v1::TeamMember& a = team.spec().team(0);
  const v1::TeamMember& b = team.spec().team(1);
  EXPECT_EQ(a.sensor().rate_hz(), 0.2);
  EXPECT_EQ(a.sensor().fov_x_deg(), team.spec().sensor().fov_x_deg());
  EXPECT_EQ(a.sensor().noise_a_var(), team.spec().sensor().noise_a_var());
  EXPECT_EQ(a.flight().max_speed_m_s(), team.spec().flight().max_speed_m_s());
  EXPECT_EQ(b.sensor().rate_hz(), 0.5);
  EXPECT_EQ(b.sensor().fov_x_deg(), 30);
  EXPECT_EQ(b.sensor().noise_a_var(), 4);
  EXPECT_EQ(b.sensor().noise_b_per_m(), team.spec().sensor().noise_b_per_m());
  EXPECT_EQ(b.flight().max_speed_m_s(), 1.5);
  EXPECT_EQ(b.flight().max_accel_m_s2(), 1);
  EXPECT_EQ(b.flight().uav_radius_m(), team.spec().flight().uav_radius_m());
  EXPECT_FALSE(b.flight().has_max_altitude_m());

  // A member that takes the detector's curve keeps the mission's camera and
  // drops A (1 - exp(-B h)).
  v1::MissionSpec detector = TeamSpec(kStarts);
  detector.mutable_team(0)->mutable_sensor()->mutable_detector_noise()->set_p_max(0.8);
  v1::Mission with_detector;
  ASSERT_TRUE(CreateTeam(service.stub(), "detector", detector, &with_detector).ok());
  const v1::SensorSpec& own = with_detector.spec().team(0).sensor();
  EXPECT_TRUE(own.has_detector_noise());
  EXPECT_EQ(own.detector_noise().p_max(), 0.8);
  EXPECT_FALSE(own.has_noise_a_var());
  EXPECT_FALSE(with_detector.spec().team(1).sensor().has_detector_noise());
  EXPECT_FALSE(with_detector.spec().sensor().has_detector_noise());
}

}  // namespace
}  // namespace oaipp::server
