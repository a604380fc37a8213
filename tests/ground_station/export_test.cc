// Ground stations, end to end in process: a mission created in latitude and
// longitude, a real plan through its obstacles, and ExportPath's .plan
// file, MAVLink items and setpoints checked against the plan itself:
// waypoints back in local metres lie on the trajectory (1 cm), the geofence
// holds the whole path, and the setpoints replay the polynomials.
#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "api/geodetic.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/server/service_fixture.h"

namespace oaipp::server {
namespace {

using nlohmann::json;
using testing::InProcessService;

using api::GeoPoint;
constexpr GeoPoint kOrigin{47.397742, 8.545594, 488.0};

v1::GeoPoint Geo(double lat, double lon, double alt) {
  v1::GeoPoint g;
  g.set_latitude_deg(lat);
  g.set_longitude_deg(lon);
  g.set_altitude_m(alt);
  return g;
}

// Horner on one axis of a segment's coefficients: value and derivatives.
double Poly(const google::protobuf::RepeatedField<double>& c, double tau, int order) {
  double v = 0.0;
  for (int k = c.size() - 1; k >= order; --k) {
    double f = 1.0;
    for (int j = 0; j < order; ++j) f *= static_cast<double>(k - j);
    v = v * tau + f * c[k];
  }
  return v;
}

// Position (order 0), velocity (1) or acceleration (2) at t, straight from
// the response's coefficients.
Vec3 Eval(const v1::Trajectory& traj, double t, int order) {
  double start = 0.0;
  for (int i = 0; i < traj.segments_size(); ++i) {
    const v1::PolynomialSegment& s = traj.segments(i);
    if (t <= start + s.duration_s() || i + 1 == traj.segments_size()) {
      const double tau = std::clamp(t - start, 0.0, s.duration_s());
      return {Poly(s.x_coefficients(), tau, order), Poly(s.y_coefficients(), tau, order),
              Poly(s.z_coefficients(), tau, order)};
    }
    start += s.duration_s();
  }
  return Vec3::Zero();
}

// Distance from p to the trajectory sampled at 1 kHz (as a polyline).
double DistanceToPath(const v1::Trajectory& traj, const Vec3& p) {
  double best = 1e9;
  Vec3 prev = Eval(traj, 0.0, 0);
  for (double t = 0.001; t < traj.duration_s() + 0.001; t += 0.001) {
    const Vec3 next = Eval(traj, std::min(t, traj.duration_s()), 0);
    const Vec3 d = next - prev;
    const double s =
        d.squaredNorm() > 0 ? std::clamp((p - prev).dot(d) / d.squaredNorm(), 0.0, 1.0) : 0.0;
    best = std::min(best, (prev + s * d - p).norm());
    prev = next;
  }
  return best;
}

bool InPolygon(const std::vector<Vec2>& poly, const Vec2& p) {
  bool inside = false;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    if ((poly[i].y() > p.y()) != (poly[j].y() > p.y()) &&
        p.x() < (poly[j].x() - poly[i].x()) * (p.y() - poly[i].y()) / (poly[j].y() - poly[i].y()) +
                    poly[i].x()) {
      inside = !inside;
    }
  }
  return inside;
}

class GroundStationTest : public ::testing::Test {
 protected:
  // A mission near Zurich: a shed given by latitude/longitude, a tall mast
  // in local metres, the start by latitude/longitude; then `edit`.
  void CreateMission(const std::function<void(v1::MissionSpec&)>& edit = {}) {
    v1::CreateMissionRequest request;
    request.set_mission_id("zurich");
    v1::MissionSpec& spec = *request.mutable_spec();
    *spec.mutable_geo_origin() =
        Geo(kOrigin.latitude_deg, kOrigin.longitude_deg, kOrigin.altitude_m);
    v1::Obstacle* shed = spec.add_obstacles();
    shed->set_id("shed");
    *shed->mutable_box()->mutable_centre_geo() =
        Geo(47.397742 + 0.00006, 8.545594 + 0.00008, 492.0);
    shed->mutable_box()->mutable_size_m()->set_x(4);
    shed->mutable_box()->mutable_size_m()->set_y(6);
    shed->mutable_box()->mutable_size_m()->set_z(8);
    v1::Obstacle* mast = spec.add_obstacles();
    mast->set_id("mast");
    mast->mutable_cylinder()->mutable_centre_m()->set_x(-6);
    mast->mutable_cylinder()->mutable_centre_m()->set_y(-5);
    mast->mutable_cylinder()->mutable_centre_m()->set_z(15);
    mast->mutable_cylinder()->set_radius_m(1.0);
    mast->mutable_cylinder()->set_height_m(30.0);
    *spec.mutable_start()->mutable_position_geo() = Geo(47.397742, 8.545594, 498.0);
    spec.mutable_planner()->set_generations(8);
    if (edit) edit(spec);
    v1::Mission mission;
    grpc::ClientContext context;
    const grpc::Status status = service_.stub().CreateMission(&context, request, &mission);
    ASSERT_TRUE(status.ok()) << status.error_message();
    mission_ = mission;
  }

  v1::PlanPathResponse Plan() {
    v1::PlanPathRequest request;
    request.set_name("missions/zurich");
    *request.mutable_state()->mutable_position_geo() = Geo(47.397742, 8.545594, 498.0);
    v1::PlanPathResponse response;
    grpc::ClientContext context;
    const grpc::Status status = service_.stub().PlanPath(&context, request, &response);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return response;
  }

  grpc::Status Export(const v1::ExportPathRequest& request, v1::ExportPathResponse* out) {
    grpc::ClientContext context;
    return service_.stub().ExportPath(&context, request, out);
  }

  // The .plan of `path` with the default options, parsed (an empty object,
  // and the test failed, if the export was refused).
  json ExportedPlan(const v1::PlanPathResponse& path) {
    v1::ExportPathRequest request;
    request.set_name("missions/zurich");
    *request.mutable_path() = path;
    v1::ExportPathResponse out;
    const grpc::Status status = Export(request, &out);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return status.ok() ? json::parse(out.qgc_plan_json()) : json::object();
  }

  InProcessService service_;
  v1::Mission mission_;
};

TEST_F(GroundStationTest, GeodeticInputBecomesLocalMetres) {
  CreateMission();
  const api::GeoFrame frame = *api::GeoFrame::FromOrigin(kOrigin);
  const Vec3 shed = frame.ToLocal({47.397742 + 0.00006, 8.545594 + 0.00008, 492.0});
  ASSERT_EQ(mission_.obstacles_size(), 2);
  const auto shed_at = std::find_if(mission_.obstacles().begin(), mission_.obstacles().end(),
                                    [](const v1::Obstacle& o) { return o.id() == "shed"; });
  ASSERT_NE(shed_at, mission_.obstacles().end());
  const v1::Vector3& c = shed_at->box().centre_m();
  EXPECT_NEAR(c.x(), shed.x(), 1e-9);
  EXPECT_NEAR(c.y(), shed.y(), 1e-9);
  EXPECT_NEAR(c.z(), 4.0, 1e-3);  // 4 m above the origin, less the Earth's curvature
  EXPECT_NEAR(mission_.spec().start().position_m().z(), 10.0, 1e-3);
  EXPECT_NEAR(mission_.spec().geo_origin().latitude_deg(), kOrigin.latitude_deg, 0.0);

  // A measurement by latitude/longitude is fused where the local one is.
  v1::AddMeasurementRequest m;
  m.set_name("missions/zurich");
  m.set_mission_time_s(1.0);
  *m.mutable_camera_position_geo() = Geo(47.397742, 8.545594, 498.0);
  m.mutable_labels()->add_cells(20 * 40 + 20);
  m.mutable_labels()->add_labels(1.0);
  m.set_request_id("geo-1");
  v1::AddMeasurementResponse answer;
  grpc::ClientContext context;
  ASSERT_TRUE(service_.stub().AddMeasurement(&context, m, &answer).ok());
  EXPECT_EQ(answer.cells_fused(), 1);

  // Both forms at once, and a geodetic point on a mission without origin.
  m.mutable_camera_position_m()->set_z(10);
  m.set_request_id("geo-2");
  grpc::ClientContext context2;
  grpc::Status status = service_.stub().AddMeasurement(&context2, m, &answer);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(absl::StartsWith(status.error_message(), "camera_position_geo: give"))
      << status.error_message();

  v1::CreateMissionRequest local;
  local.set_mission_id("local");
  *local.mutable_spec()->mutable_start()->mutable_position_geo() = Geo(47.4, 8.5, 500.0);
  v1::Mission unused;
  grpc::ClientContext context3;
  status = service_.stub().CreateMission(&context3, local, &unused);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(absl::StartsWith(status.error_message(),
                               "spec.start.position_geo: the mission has no geo_origin"))
      << status.error_message();
}

TEST_F(GroundStationTest, ThePlanFileHasQGroundControlsFieldsAndFollowsThePath) {
  CreateMission();
  const v1::PlanPathResponse path = Plan();
  ASSERT_GT(path.trajectory().segments_size(), 0);
  v1::ExportPathRequest request;
  request.set_name("missions/zurich");
  *request.mutable_path() = path;
  request.set_waypoint_tolerance_m(0.2);
  v1::ExportPathResponse out;
  const grpc::Status status = Export(request, &out);
  ASSERT_TRUE(status.ok()) << status.error_message();

  const json plan = json::parse(out.qgc_plan_json());
  EXPECT_EQ(plan.at("fileType"), "Plan");
  EXPECT_EQ(plan.at("version"), 1);
  EXPECT_TRUE(plan.at("groundStation").is_string());
  const json& mission = plan.at("mission");
  EXPECT_EQ(mission.at("version"), 2);
  EXPECT_EQ(mission.at("firmwareType"), 12);
  EXPECT_EQ(mission.at("vehicleType"), 2);
  EXPECT_TRUE(mission.at("cruiseSpeed").is_number());
  EXPECT_TRUE(mission.at("hoverSpeed").is_number());
  // Home: the ground under the mission's start (given by latitude and
  // longitude), not the frame's origin.
  const json& home = mission.at("plannedHomePosition");
  ASSERT_EQ(home.size(), 3u);
  EXPECT_NEAR(home[0].get<double>(), 47.397742, 1e-9);
  EXPECT_NEAR(home[1].get<double>(), 8.545594, 1e-9);
  EXPECT_NEAR(home[2].get<double>(), kOrigin.altitude_m, 0.01);
  const json& items = mission.at("items");
  ASSERT_TRUE(items.is_array());
  ASSERT_EQ(items.size(), static_cast<std::size_t>(out.mission_items_size()));

  const api::GeoFrame frame = *api::GeoFrame::FromOrigin(kOrigin);
  int waypoints = 0;
  int shots = 0;
  int speeds = 0;
  for (std::size_t k = 0; k < items.size(); ++k) {
    const json& item = items[k];
    EXPECT_EQ(item.at("type"), "SimpleItem");
    EXPECT_EQ(item.at("autoContinue"), true);
    EXPECT_EQ(item.at("doJumpId"), static_cast<int>(k + 1));
    ASSERT_EQ(item.at("params").size(), 7u);
    const int command = item.at("command");
    const v1::MissionItem& raw = out.mission_items(static_cast<int>(k));
    EXPECT_EQ(raw.seq(), k);
    EXPECT_EQ(raw.command(), static_cast<std::uint32_t>(command));
    EXPECT_EQ(raw.current(), k == 0 ? 1u : 0u);
    if (command == 16) {
      ++waypoints;
      EXPECT_EQ(item.at("frame"), 3);  // relative to home; never the deprecated _INT frames
      EXPECT_EQ(raw.frame(), 3u);
      const json& p = item.at("params");
      // Back in local metres: on the trajectory, to 1 cm.
      const Vec3 local = frame.ToLocal(
          {p[4].get<double>(), p[5].get<double>(), kOrigin.altitude_m + p[6].get<double>()});
      EXPECT_LT(DistanceToPath(path.trajectory(), local), 0.01) << "item " << k;
      // The MAVLink item's 1e-7 degree integers too.
      const Vec3 from_raw =
          frame.ToLocal({raw.x() * 1e-7, raw.y() * 1e-7, kOrigin.altitude_m + raw.z()});
      EXPECT_LT(DistanceToPath(path.trajectory(), from_raw), 0.01) << "item " << k;
    } else if (command == 2000) {
      ++shots;
      EXPECT_EQ(raw.frame(), 2u);
      // One image each, numbered 1, 2, ... (MAVLink's sequence number, so
      // that a command sent twice shoots once).
      EXPECT_EQ(raw.param3(), 1.0f);
      EXPECT_EQ(raw.param4(), static_cast<float>(shots)) << "item " << k;
      EXPECT_EQ(item.at("params")[3].get<double>(), shots);
    } else {
      EXPECT_EQ(command, 178);
      ++speeds;
      EXPECT_GT(raw.param2(), 0.0f);
      EXPECT_LE(raw.param2(), 5.0f + 1e-3f);
    }
  }
  EXPECT_GE(waypoints, 2);
  EXPECT_EQ(shots, path.measurement_poses_size());
  EXPECT_GE(speeds, 1);
  EXPECT_LE(out.waypoint_deviation_m(), 0.2);

  // The geofence: the inclusion polygon holds every point of the path; no
  // point lies in an exclusion zone.
  const json& fence = plan.at("geoFence");
  EXPECT_EQ(fence.at("version"), 2);
  std::vector<std::vector<Vec2>> inclusions, exclusions;
  for (const json& poly : fence.at("polygons")) {
    EXPECT_EQ(poly.at("version"), 1);
    std::vector<Vec2> corners;
    for (const json& c : poly.at("polygon")) {
      corners.push_back(
          frame.ToLocal({c[0].get<double>(), c[1].get<double>(), kOrigin.altitude_m}).head<2>());
    }
    (poly.at("inclusion").get<bool>() ? inclusions : exclusions).push_back(corners);
  }
  ASSERT_EQ(inclusions.size(), 1u);
  std::vector<std::pair<Vec2, double>> circles;
  for (const json& c : fence.at("circles")) {
    EXPECT_FALSE(c.at("inclusion").get<bool>());
    const json& centre = c.at("circle").at("center");
    circles.emplace_back(
        frame.ToLocal({centre[0].get<double>(), centre[1].get<double>(), kOrigin.altitude_m})
            .head<2>(),
        c.at("circle").at("radius").get<double>());
  }
  // The mast (30 m, above the flight ceiling) cannot be overflown: fenced.
  EXPECT_EQ(circles.size() + exclusions.size() + out.overflown_obstacles_size(), 2u);
  EXPECT_EQ(circles.size(), 1u);
  for (double t = 0.0; t <= path.trajectory().duration_s(); t += 0.01) {
    const Vec2 p = Eval(path.trajectory(), t, 0).head<2>();
    ASSERT_TRUE(InPolygon(inclusions[0], p)) << "t = " << t;
    for (const auto& poly : exclusions) ASSERT_FALSE(InPolygon(poly, p)) << "t = " << t;
    for (const auto& [centre, radius] : circles) ASSERT_GT((p - centre).norm(), radius);
  }
  // Home lies inside the fence and outside every exclusion.
  const Vec2 home_local =
      frame.ToLocal({home[0].get<double>(), home[1].get<double>(), kOrigin.altitude_m}).head<2>();
  EXPECT_TRUE(InPolygon(inclusions[0], home_local));
  for (const auto& poly : exclusions) EXPECT_FALSE(InPolygon(poly, home_local));
  for (const auto& [centre, radius] : circles) EXPECT_GT((home_local - centre).norm(), radius);
  EXPECT_EQ(plan.at("rallyPoints").at("version"), 2);
  ASSERT_EQ(plan.at("rallyPoints").at("points").size(), 1u);
  EXPECT_EQ(plan.at("rallyPoints").at("points")[0].size(), 3u);
}

// The mission's own fence is fenced in (a circle given in WGS84) and its
// no-fly zones out, but for one the path passes under (its floor is above
// the flight ceiling): no point of the path is outside the fence's circle
// or in the tower's.
TEST_F(GroundStationTest, TheMissionsFenceIsFencedInAndItsZonesOut) {
  CreateMission([](v1::MissionSpec& spec) {
    v1::Circle& circle = *spec.mutable_fence()->mutable_circle();
    *circle.mutable_centre_geo() = Geo(47.397742, 8.545594, 0.0);
    circle.set_radius_m(14.0);
    v1::Obstacle& tower = *spec.add_no_fly_zones();
    tower.set_id("tower");
    tower.mutable_cylinder()->mutable_centre_m()->set_x(8);
    tower.mutable_cylinder()->mutable_centre_m()->set_y(-8);
    tower.mutable_cylinder()->mutable_centre_m()->set_z(20);
    tower.mutable_cylinder()->set_radius_m(1.5);
    tower.mutable_cylinder()->set_height_m(40);
    v1::Obstacle& high = *spec.add_no_fly_zones();
    high.set_id("high");
    for (const double v : {-15.0, -15.0, 15.0, -15.0, 15.0, 15.0, -15.0, 15.0}) {
      high.mutable_prism()->mutable_footprint()->add_xy_m(v);
    }
    high.mutable_prism()->set_base_m(28.0);
    high.mutable_prism()->set_top_m(60.0);
  });
  const v1::PlanPathResponse path = Plan();
  ASSERT_GT(path.trajectory().segments_size(), 0);
  const json plan = ExportedPlan(path);
  const api::GeoFrame frame = *api::GeoFrame::FromOrigin(kOrigin);
  const json& fence = plan.at("geoFence");
  int inclusion_polygons = 0, exclusion_polygons = 0;
  for (const json& poly : fence.at("polygons")) {
    (poly.at("inclusion").get<bool>() ? inclusion_polygons : exclusion_polygons) += 1;
  }
  EXPECT_EQ(inclusion_polygons, 1);  // the field's; "high" is not fenced
  std::vector<std::pair<Vec2, double>> in, out_of;
  for (const json& c : fence.at("circles")) {
    const json& centre = c.at("circle").at("center");
    const Vec2 local =
        frame.ToLocal({centre[0].get<double>(), centre[1].get<double>(), kOrigin.altitude_m})
            .head<2>();
    (c.at("inclusion").get<bool>() ? in : out_of)
        .emplace_back(local, c.at("circle").at("radius").get<double>());
  }
  ASSERT_EQ(in.size(), 1u);
  const Vec2 start_local = frame.ToLocal({47.397742, 8.545594, kOrigin.altitude_m}).head<2>();
  EXPECT_LT((in[0].first - start_local).norm(), 0.01);
  EXPECT_EQ(in[0].second, 14.0);
  // The mast and the tower (the shed is a polygon or overflown).
  ASSERT_EQ(out_of.size(), 2u);
  EXPECT_TRUE(std::any_of(out_of.begin(), out_of.end(), [](const auto& c) {
    return (c.first - Vec2(8, -8)).norm() < 0.01 && c.second == 1.5;
  }));
  for (double t = 0.0; t <= path.trajectory().duration_s(); t += 0.01) {
    const Vec2 p = Eval(path.trajectory(), t, 0).head<2>();
    ASSERT_LT((p - in[0].first).norm(), in[0].second) << "t = " << t;
    for (const auto& [centre, radius] : out_of) ASSERT_GT((p - centre).norm(), radius);
  }
}

// With a home (MissionSpec.home, given by latitude and longitude), the
// .plan's one rally point is that home, its altitude relative to the
// planned home position; and the plan leaves a way home, ending there.
TEST_F(GroundStationTest, TheRallyPointIsTheMissionsHome) {
  const v1::GeoPoint home_geo = Geo(47.397742 + 0.00005, 8.545594 - 0.00009, 494.0);
  CreateMission([&](v1::MissionSpec& spec) {
    *spec.mutable_home()->mutable_position_geo() = home_geo;
    spec.mutable_home()->set_reserve_s(10);
  });
  const v1::PlanPathResponse path = Plan();
  ASSERT_GT(path.trajectory().segments_size(), 0);
  ASSERT_TRUE(path.has_way_home());
  const api::GeoFrame frame = *api::GeoFrame::FromOrigin(kOrigin);
  const Vec3 home_local =
      frame.ToLocal({home_geo.latitude_deg(), home_geo.longitude_deg(), home_geo.altitude_m()});
  const double last = path.way_home().duration_s();
  EXPECT_LT((Eval(path.way_home(), last, 0) - home_local).norm(), 1e-6);
  const json plan = ExportedPlan(path);
  const json& planned_home = plan.at("mission").at("plannedHomePosition");
  const json& points = plan.at("rallyPoints").at("points");
  ASSERT_EQ(points.size(), 1u);
  EXPECT_NEAR(points[0][0].get<double>(), home_geo.latitude_deg(), 1e-9);
  EXPECT_NEAR(points[0][1].get<double>(), home_geo.longitude_deg(), 1e-9);
  EXPECT_NEAR(points[0][2].get<double>(), home_geo.altitude_m() - planned_home[2].get<double>(),
              1e-3);
}

// A team's export is per UAV: each path names its uav_id, and its .plan's
// home is the ground under that UAV's own start (given here by latitude and
// longitude), not the mission's. A path without a uav_id, or naming a UAV
// not in the team, is refused naming path.uav_id.
TEST_F(GroundStationTest, EachUavOfATeamExportsItsPathWithItsHomeUnderItsStart) {
  const v1::GeoPoint starts[] = {Geo(47.397742 + 0.00005, 8.545594 - 0.0001, 496.0),
                                 Geo(47.397742 - 0.00005, 8.545594 + 0.0001, 496.0)};
  v1::CreateMissionRequest create;
  create.set_mission_id("team");
  v1::MissionSpec& spec = *create.mutable_spec();
  *spec.mutable_geo_origin() = Geo(kOrigin.latitude_deg, kOrigin.longitude_deg, kOrigin.altitude_m);
  spec.mutable_planner()->set_generations(4);
  for (int i = 0; i < 2; ++i) {
    v1::TeamMember& m = *spec.add_team();
    m.set_uav_id(i == 0 ? "north" : "south");
    *m.mutable_start()->mutable_position_geo() = starts[i];
  }
  v1::Mission mission;
  {
    grpc::ClientContext context;
    const grpc::Status status = service_.stub().CreateMission(&context, create, &mission);
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  for (int i = 0; i < 2; ++i) {
    v1::PlanPathRequest plan;
    plan.set_name("missions/team");
    plan.set_uav_id(mission.spec().team(i).uav_id());
    *plan.mutable_state()->mutable_position_geo() = starts[i];
    v1::ExportPathRequest request;
    request.set_name("missions/team");
    {
      grpc::ClientContext context;
      const grpc::Status status = service_.stub().PlanPath(&context, plan, request.mutable_path());
      ASSERT_TRUE(status.ok()) << status.error_message();
    }
    EXPECT_EQ(request.path().uav_id(), plan.uav_id());
    v1::ExportPathResponse out;
    const grpc::Status status = Export(request, &out);
    ASSERT_TRUE(status.ok()) << status.error_message();
    const json home = json::parse(out.qgc_plan_json()).at("mission").at("plannedHomePosition");
    EXPECT_NEAR(home[0].get<double>(), starts[i].latitude_deg(), 1e-9) << plan.uav_id();
    EXPECT_NEAR(home[1].get<double>(), starts[i].longitude_deg(), 1e-9) << plan.uav_id();
    EXPECT_NEAR(home[2].get<double>(), kOrigin.altitude_m, 0.01);

    for (const auto& [uav_id, code] : {std::pair{"", grpc::StatusCode::INVALID_ARGUMENT},
                                       std::pair{"west", grpc::StatusCode::NOT_FOUND}}) {
      v1::ExportPathRequest bad = request;
      bad.mutable_path()->set_uav_id(uav_id);
      const grpc::Status refused = Export(bad, &out);
      EXPECT_EQ(refused.error_code(), code) << uav_id;
      EXPECT_TRUE(absl::StrContains(refused.error_message(), "path.uav_id"))
          << refused.error_message();
    }
  }
}

TEST_F(GroundStationTest, SetpointsReplayThePolynomialsInNed) {
  CreateMission();
  const v1::PlanPathResponse path = Plan();
  v1::ExportPathRequest request;
  request.set_name("missions/zurich");
  *request.mutable_path() = path;
  request.set_setpoint_rate_hz(25.0);
  v1::ExportPathResponse out;
  ASSERT_TRUE(Export(request, &out).ok());
  const double duration = path.trajectory().duration_s();
  ASSERT_EQ(out.setpoints_size(), static_cast<int>(std::ceil(duration * 25.0 - 1e-9)) + 1);
  for (int i = 0; i < out.setpoints_size(); ++i) {
    const v1::Setpoint& s = out.setpoints(i);
    const double t = i + 1 < out.setpoints_size() ? i / 25.0 : duration;
    EXPECT_NEAR(s.t_s(), t, 1e-12);
    const Vec3 p = Eval(path.trajectory(), t, 0);
    const Vec3 v = Eval(path.trajectory(), t, 1);
    const Vec3 a = Eval(path.trajectory(), t, 2);
    EXPECT_NEAR(s.position_ned_m().x(), p.y(), 1e-9);  // north = y
    EXPECT_NEAR(s.position_ned_m().y(), p.x(), 1e-9);  // east = x
    EXPECT_NEAR(s.position_ned_m().z(), -p.z(), 1e-9);
    EXPECT_NEAR(s.velocity_ned_m_s().x(), v.y(), 1e-9);
    EXPECT_NEAR(s.velocity_ned_m_s().z(), -v.z(), 1e-9);
    EXPECT_NEAR(s.acceleration_ned_m_s2().y(), a.x(), 1e-8);
    EXPECT_NEAR(s.acceleration_ned_m_s2().z(), -a.z(), 1e-8);
    EXPECT_EQ(s.yaw_deg(), 90.0);
  }
}

TEST_F(GroundStationTest, FewItemsLoosenTheToleranceAndBadOptionsAreNamed) {
  CreateMission();
  const v1::PlanPathResponse path = Plan();
  v1::ExportPathRequest request;
  request.set_name("missions/zurich");
  *request.mutable_path() = path;
  request.set_waypoint_tolerance_m(0.01);
  request.set_max_items(std::max(8, 3 * path.measurement_poses_size() + 4));
  v1::ExportPathResponse out;
  grpc::Status status = Export(request, &out);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_LE(out.mission_items_size(), request.max_items());

  for (const auto& [field, set] :
       std::vector<std::pair<std::string, std::function<void(v1::ExportPathRequest&)>>>{
           {"setpoint_rate_hz", [](auto& r) { r.set_setpoint_rate_hz(5.0); }},
           {"waypoint_tolerance_m", [](auto& r) { r.set_waypoint_tolerance_m(-1.0); }},
           {"max_items", [](auto& r) { r.set_max_items(3); }},
           {"path.measurement_poses[0].t_s",
            [](auto& r) { r.mutable_path()->mutable_measurement_poses(0)->set_t_s(-1.0); }},
           {"path.trajectory.segments", [](auto& r) { r.mutable_path()->clear_trajectory(); }},
           {"path: required", [](auto& r) { r.clear_path(); }}}) {
    v1::ExportPathRequest bad = request;
    set(bad);
    status = Export(bad, &out);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << field;
    EXPECT_TRUE(absl::StartsWith(status.error_message(), field)) << status.error_message();
  }
}

TEST_F(GroundStationTest, WithoutAnOriginOnlySetpointsAreExported) {
  v1::CreateMissionRequest create;
  create.set_mission_id("local");
  create.mutable_spec()->mutable_planner()->set_generations(4);
  v1::Mission unused;
  grpc::ClientContext context;
  ASSERT_TRUE(service_.stub().CreateMission(&context, create, &unused).ok());
  v1::PlanPathRequest plan;
  plan.set_name("missions/local");
  plan.mutable_state()->mutable_position_m()->set_z(10.0);
  v1::PlanPathResponse path;
  grpc::ClientContext context2;
  ASSERT_TRUE(service_.stub().PlanPath(&context2, plan, &path).ok());
  v1::ExportPathRequest request;
  request.set_name("missions/local");
  *request.mutable_path() = path;
  v1::ExportPathResponse out;
  ASSERT_TRUE(Export(request, &out).ok());
  EXPECT_TRUE(out.qgc_plan_json().empty());
  EXPECT_EQ(out.mission_items_size(), 0);
  EXPECT_GT(out.setpoints_size(), 10);
}

}  // namespace
}  // namespace oaipp::server
