// A table of bad requests, each with its expected status code and the field
// its message must name; the server keeps serving afterwards.
#include <functional>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "api/limits.h"
#include "api/search_area.h"
#include "gtest/gtest.h"
#include "tests/server/service_fixture.h"

namespace oaipp::server {
namespace {

using testing::CreateSmall;
using testing::InProcessService;
using testing::LabelMeasurement;
using testing::SmallSpec;

struct BadCase {
  std::string name;
  grpc::StatusCode code;
  std::string field;  // substring the message must contain
  std::function<grpc::Status(v1::MissionService::Stub&)> call;
};

grpc::Status Create(v1::MissionService::Stub& stub, const std::string& id,
                    const std::function<void(v1::MissionSpec&)>& edit) {
  grpc::ClientContext context;
  v1::CreateMissionRequest request;
  request.set_mission_id(id);
  *request.mutable_spec() = SmallSpec();
  edit(*request.mutable_spec());
  v1::Mission m;
  return stub.CreateMission(&context, request, &m);
}

grpc::Status Measure(v1::MissionService::Stub& stub,
                     const std::function<void(v1::AddMeasurementRequest&)>& edit) {
  grpc::ClientContext context;
  v1::AddMeasurementRequest request = LabelMeasurement("missions/ok", 2, 2, 10, 5, 1);
  edit(request);
  v1::AddMeasurementResponse r;
  return stub.AddMeasurement(&context, request, &r);
}

grpc::Status Plan(v1::MissionService::Stub& stub,
                  const std::function<void(v1::PlanPathRequest&)>& edit) {
  grpc::ClientContext context;
  v1::PlanPathRequest request;
  request.set_name("missions/ok");
  request.mutable_state()->mutable_position_m()->set_x(-4);
  request.mutable_state()->mutable_position_m()->set_y(4);
  request.mutable_state()->mutable_position_m()->set_z(8);
  edit(request);
  v1::PlanPathResponse r;
  return stub.PlanPath(&context, request, &r);
}

grpc::Status Obstacles(v1::MissionService::Stub& stub,
                       const std::function<void(v1::UpdateObstaclesRequest&)>& edit) {
  grpc::ClientContext context;
  v1::UpdateObstaclesRequest request;
  request.set_name("missions/ok");
  edit(request);
  v1::UpdateObstaclesResponse r;
  return stub.UpdateObstacles(&context, request, &r);
}

v1::Obstacle BoxAt(const std::string& id, double x, double y, double sx) {
  v1::Obstacle o;
  o.set_id(id);
  o.mutable_box()->mutable_centre_m()->set_x(x);
  o.mutable_box()->mutable_centre_m()->set_y(y);
  o.mutable_box()->mutable_centre_m()->set_z(3);
  o.mutable_box()->mutable_size_m()->set_x(sx);
  o.mutable_box()->mutable_size_m()->set_y(1);
  o.mutable_box()->mutable_size_m()->set_z(6);
  return o;
}

// A 2 x 1 x 20 m tower (y from y - 0.5 to y + 0.5).
v1::Obstacle TowerAt(double x, double y) {
  v1::Obstacle o = BoxAt("tower", x, y, 2);
  o.mutable_box()->mutable_centre_m()->set_z(10);
  o.mutable_box()->mutable_size_m()->set_z(20);
  return o;
}

const auto kInvalid = grpc::StatusCode::INVALID_ARGUMENT;

std::vector<BadCase> Cases() {
  return {
      {"bad id", kInvalid, "mission_id", [](auto& s) { return Create(s, "Bad_Id", [](auto&) {}); }},
      {"taken id", grpc::StatusCode::ALREADY_EXISTS, "mission_id",
       [](auto& s) { return Create(s, "ok", [](auto&) {}); }},
      {"unknown preset", kInvalid, "spec.preset",
       [](auto& s) { return Create(s, "x1", [](auto& p) { p.set_preset("moon"); }); }},
      {"zero resolution", kInvalid, "resolution_m",
       [](auto& s) {
         return Create(s, "x2", [](auto& p) { p.mutable_field()->set_resolution_m(0); });
       }},
      {"NaN field", kInvalid, "field",
       [](auto& s) {
         return Create(s, "x3", [](auto& p) { p.mutable_field()->set_x_max_m(NAN); });
       }},
      {"inverted field", kInvalid, "field",
       [](auto& s) {
         return Create(s, "x4", [](auto& p) { p.mutable_field()->set_x_max_m(-10); });
       }},
      {"fractional cells", kInvalid, "field",
       [](auto& s) {
         return Create(s, "x5", [](auto& p) { p.mutable_field()->set_resolution_m(0.7); });
       }},
      {"negative length scale", kInvalid, "length_scale_m",
       [](auto& s) {
         return Create(s, "x6", [](auto& p) { p.mutable_gp()->set_length_scale_m(-1); });
       }},
      {"zero sensor rate", kInvalid, "rate_hz",
       [](auto& s) {
         return Create(s, "x7", [](auto& p) { p.mutable_sensor()->set_rate_hz(0); });
       }},
      {"start inside a building", kInvalid, "spec.start.position_m",
       [](auto& s) {
         return Create(s, "x10", [](auto& p) { *p.add_obstacles() = TowerAt(-4, 4); });
       }},
      {"start grazing a building", kInvalid, "spec.start.position_m",
       [](auto& s) {
         // The tower's face is 0.3 m from the start: less than uav_radius_m / 2.
         return Create(s, "x11", [](auto& p) { *p.add_obstacles() = TowerAt(-4, 4.8); });
       }},
      {"fov 200 deg", kInvalid, "fov",
       [](auto& s) {
         return Create(s, "x8", [](auto& p) { p.mutable_sensor()->set_fov_x_deg(200); });
       }},
      {"fov 3e-307 deg", kInvalid, "spec.sensor.fov_y_deg",
       [](auto& s) {
         return Create(s, "x8", [](auto& p) { p.mutable_sensor()->set_fov_y_deg(3.3e-307); });
       }},
      {"noise 1e20 x the signal", kInvalid, "spec.gp.noise_var",
       [](auto& s) {
         return Create(s, "x8", [](auto& p) { p.mutable_gp()->set_noise_var(1e20); });
       }},
      {"altitudes inverted", kInvalid, "altitude",
       [](auto& s) {
         return Create(s, "x9", [](auto& p) { p.mutable_flight()->set_min_altitude_m(30); });
       }},
      {"zero speed", kInvalid, "max_speed_m_s",
       [](auto& s) {
         return Create(s, "x10", [](auto& p) { p.mutable_flight()->set_max_speed_m_s(0); });
       }},
      {"tiny population", kInvalid, "population",
       [](auto& s) {
         return Create(s, "x11", [](auto& p) { p.mutable_planner()->set_population(2); });
       }},
      {"one waypoint", kInvalid, "num_waypoints",
       [](auto& s) {
         return Create(s, "x12", [](auto& p) { p.mutable_planner()->set_num_waypoints(1); });
       }},
      {"unknown planner kind", kInvalid, "kind",
       [](auto& s) {
         return Create(s, "x13", [](auto& p) {
           p.mutable_planner()->set_kind(static_cast<v1::PlannerKind>(42));
         });
       }},
      {"zero budget", kInvalid, "budget_s",
       [](auto& s) { return Create(s, "x14", [](auto& p) { p.set_budget_s(0); }); }},
      {"duplicate obstacle ids", kInvalid, "obstacles",
       [](auto& s) {
         return Create(s, "x15", [](auto& p) { *p.add_obstacles() = p.obstacles(0); });
       }},
      {"zero-size box", kInvalid, "size_m",
       [](auto& s) {
         return Create(s, "x16", [](auto& p) {
           p.mutable_obstacles(0)->mutable_box()->mutable_size_m()->set_x(0);
         });
       }},
      {"obstacle without shape", kInvalid, "obstacles",
       [](auto& s) {
         return Create(s, "x17", [](auto& p) { p.add_obstacles()->set_id("empty"); });
       }},
      {"NaN start", kInvalid, "start",
       [](auto& s) {
         return Create(s, "x18",
                       [](auto& p) { p.mutable_start()->mutable_position_m()->set_z(NAN); });
       }},
      {"malformed name", kInvalid, "name",
       [](auto& s) { return Measure(s, [](auto& r) { r.set_name("mission/ok"); }); }},
      {"unknown mission", grpc::StatusCode::NOT_FOUND, "name",
       [](auto& s) { return Measure(s, [](auto& r) { r.set_name("missions/nope"); }); }},
      {"measurement without data", kInvalid, "data",
       [](auto& s) { return Measure(s, [](auto& r) { r.clear_labels(); }); }},
      {"label length mismatch", kInvalid, "labels",
       [](auto& s) { return Measure(s, [](auto& r) { r.mutable_labels()->add_cells(399); }); }},
      {"label out of [0, 1]", kInvalid, "labels",
       [](auto& s) { return Measure(s, [](auto& r) { r.mutable_labels()->set_labels(0, 3); }); }},
      {"cell outside the field", kInvalid, "cells",
       [](auto& s) { return Measure(s, [](auto& r) { r.mutable_labels()->set_cells(0, 400); }); }},
      {"NaN camera", kInvalid, "camera_position_m",
       [](auto& s) {
         return Measure(s, [](auto& r) { r.mutable_camera_position_m()->set_x(NAN); });
       }},
      {"camera above the volume", kInvalid, "camera_position_m",
       [](auto& s) {
         return Measure(s, [](auto& r) { r.mutable_camera_position_m()->set_z(80); });
       }},
      {"negative time", kInvalid, "mission_time_s",
       [](auto& s) { return Measure(s, [](auto& r) { r.set_mission_time_s(-1); }); }},
      {"box outside image", kInvalid, "x_max_px",
       [](auto& s) {
         return Measure(s, [](auto& r) {
           auto* b = r.mutable_detections()->add_boxes();
           b->set_x_min_px(10);
           b->set_y_min_px(10);
           b->set_x_max_px(5000);
           b->set_y_max_px(20);
         });
       }},
      {"bad focal length", kInvalid, "fx_px",
       [](auto& s) {
         return Measure(s, [](auto& r) {
           auto* d = r.mutable_detections();
           d->mutable_intrinsics()->set_fx_px(-5);
           d->mutable_intrinsics()->set_fy_px(500);
           d->mutable_intrinsics()->set_width_px(480);
           d->mutable_intrinsics()->set_height_px(640);
         });
       }},
      {"plan without state", kInvalid, "state",
       [](auto& s) { return Plan(s, [](auto& r) { r.clear_state(); }); }},
      {"plan from NaN", kInvalid, "state",
       [](auto& s) {
         return Plan(s, [](auto& r) { r.mutable_state()->mutable_velocity_m_s()->set_y(NAN); });
       }},
      // A well-formed state the mission's world refuses (the building may
      // have been added after the UAV got there): FAILED_PRECONDITION.
      {"plan after the budget is spent", grpc::StatusCode::FAILED_PRECONDITION,
       "state.mission_time_s: the flight budget of 60 s is spent",
       [](auto& s) { return Plan(s, [](auto& r) { r.mutable_state()->set_mission_time_s(61); }); }},
      {"plan from inside the building", grpc::StatusCode::FAILED_PRECONDITION, "inside an obstacle",
       [](auto& s) {
         return Plan(s, [](auto& r) {
           r.mutable_state()->mutable_position_m()->set_x(0);
           r.mutable_state()->mutable_position_m()->set_y(-2);
         });
       }},
      {"plan from outside the volume", kInvalid, "outside the flight volume",
       [](auto& s) {
         return Plan(s, [](auto& r) { r.mutable_state()->mutable_position_m()->set_x(30); });
       }},
      {"plan too fast", kInvalid, "max_speed",
       [](auto& s) {
         return Plan(s, [](auto& r) { r.mutable_state()->mutable_velocity_m_s()->set_x(20); });
       }},
      {"shot in the past", kInvalid, "next_shot_mission_s",
       [](auto& s) {
         return Plan(s, [](auto& r) {
           r.mutable_state()->set_mission_time_s(10);
           r.set_next_shot_mission_s(2);
         });
       }},
      {"remove unknown obstacle", grpc::StatusCode::NOT_FOUND, "remove",
       [](auto& s) { return Obstacles(s, [](auto& r) { r.add_remove("ghost"); }); }},
      {"add existing obstacle", grpc::StatusCode::ALREADY_EXISTS, "b1",
       [](auto& s) { return Obstacles(s, [](auto& r) { *r.add_add() = BoxAt("b1", 5, 5, 1); }); }},
      {"add twice in one change", kInvalid, "twin",
       [](auto& s) {
         return Obstacles(s, [](auto& r) {
           *r.add_add() = BoxAt("twin", 5, 5, 1);
           *r.add_add() = BoxAt("twin", 6, 6, 1);
         });
       }},
      {"negative box size", kInvalid, "size_m",
       [](auto& s) {
         return Obstacles(s, [](auto& r) { *r.add_add() = BoxAt("neg", 5, 5, -1); });
       }},
      {"list page too big", kInvalid, "page_size",
       [](auto& s) {
         grpc::ClientContext c;
         v1::ListMissionsRequest r;
         r.set_page_size(5000);
         v1::ListMissionsResponse out;
         return s.ListMissions(&c, r, &out);
       }},
      {"list bad token", kInvalid, "page_token",
       [](auto& s) {
         grpc::ClientContext c;
         v1::ListMissionsRequest r;
         r.set_page_token("zzz");
         v1::ListMissionsResponse out;
         return s.ListMissions(&c, r, &out);
       }},
      {"delete unknown", grpc::StatusCode::NOT_FOUND, "name",
       [](auto& s) {
         grpc::ClientContext c;
         v1::DeleteMissionRequest r;
         r.set_name("missions/ghost");
         v1::DeleteMissionResponse out;
         return s.DeleteMission(&c, r, &out);
       }},
  };
}

// Every number of a spec that must be finite, as NaN and as +infinity: the
// error names the field by its API path.
void AddNonFiniteSpecCases(std::vector<BadCase>& cases) {
  using Edit = std::function<void(v1::MissionSpec&, double)>;
  const std::vector<std::pair<std::string, Edit>> fields = {
      {"spec.field.resolution_m",
       [](auto& s, double v) { s.mutable_field()->set_resolution_m(v); }},
      {"spec.field.x_min_m", [](auto& s, double v) { s.mutable_field()->set_x_min_m(v); }},
      {"spec.field.y_min_m", [](auto& s, double v) { s.mutable_field()->set_y_min_m(v); }},
      {"spec.flight.esdf_truncation_m",
       [](auto& s, double v) { s.mutable_flight()->set_esdf_truncation_m(v); }},
      {"spec.gp.length_scale_m", [](auto& s, double v) { s.mutable_gp()->set_length_scale_m(v); }},
      {"spec.gp.signal_var", [](auto& s, double v) { s.mutable_gp()->set_signal_var(v); }},
      {"spec.gp.noise_var", [](auto& s, double v) { s.mutable_gp()->set_noise_var(v); }},
      {"spec.gp.prior_mean", [](auto& s, double v) { s.mutable_gp()->set_prior_mean(v); }},
      {"spec.sensor.fov_x_deg", [](auto& s, double v) { s.mutable_sensor()->set_fov_x_deg(v); }},
      {"spec.sensor.noise_a_var",
       [](auto& s, double v) { s.mutable_sensor()->set_noise_a_var(v); }},
      {"spec.sensor.noise_b_per_m",
       [](auto& s, double v) { s.mutable_sensor()->set_noise_b_per_m(v); }},
      {"spec.sensor.rate_hz", [](auto& s, double v) { s.mutable_sensor()->set_rate_hz(v); }},
      {"spec.sensor.detector_noise.p_max",
       [](auto& s, double v) { s.mutable_sensor()->mutable_detector_noise()->set_p_max(v); }},
      {"spec.sensor.detector_noise.h_best_m",
       [](auto& s, double v) { s.mutable_sensor()->mutable_detector_noise()->set_h_best_m(v); }},
      {"spec.sensor.detector_noise.width_m",
       [](auto& s, double v) { s.mutable_sensor()->mutable_detector_noise()->set_width_m(v); }},
      {"spec.sensor.detector_noise.false_positive_rate",
       [](auto& s, double v) {
         s.mutable_sensor()->mutable_detector_noise()->set_false_positive_rate(v);
       }},
      {"spec.flight.max_altitude_m",
       [](auto& s, double v) { s.mutable_flight()->set_max_altitude_m(v); }},
      {"spec.flight.max_speed_m_s",
       [](auto& s, double v) { s.mutable_flight()->set_max_speed_m_s(v); }},
      {"spec.flight.max_accel_m_s2",
       [](auto& s, double v) { s.mutable_flight()->set_max_accel_m_s2(v); }},
      {"spec.flight.uav_radius_m",
       [](auto& s, double v) { s.mutable_flight()->set_uav_radius_m(v); }},
      {"spec.flight.esdf_voxel_m",
       [](auto& s, double v) { s.mutable_flight()->set_esdf_voxel_m(v); }},
      {"spec.planner.kappa", [](auto& s, double v) { s.mutable_planner()->set_kappa(v); }},
      {"spec.planner.h_opt_m", [](auto& s, double v) { s.mutable_planner()->set_h_opt_m(v); }},
      {"spec.planner.sigma1_m", [](auto& s, double v) { s.mutable_planner()->set_sigma1_m(v); }},
      {"spec.planner.h_sat_m", [](auto& s, double v) { s.mutable_planner()->set_h_sat_m(v); }},
      {"spec.planner.lawnmower_altitude_m",
       [](auto& s, double v) { s.mutable_planner()->set_lawnmower_altitude_m(v); }},
  };
  for (const auto& [field, edit] : fields) {
    for (const double value : {static_cast<double>(NAN), static_cast<double>(INFINITY)}) {
      cases.push_back(
          {absl::StrCat(field, " = ", value), kInvalid, field, [edit = edit, value](auto& s) {
             return Create(s, "nonfinite", [&](auto& spec) { edit(spec, value); });
           }});
    }
  }
}

// The documented upper bounds (api/limits.h), each refused naming its field.
void AddLimitCases(std::vector<BadCase>& cases) {
  cases.push_back({"population above the bound", kInvalid, "spec.planner.population", [](auto& s) {
                     return Create(s, "big", [](auto& spec) {
                       spec.mutable_planner()->set_population(api::kMaxPopulation + 1);
                     });
                   }});
  cases.push_back({"population 2^31-1", kInvalid, "spec.planner.population", [](auto& s) {
                     return Create(s, "big", [](auto& spec) {
                       spec.mutable_planner()->set_population(2147483647);
                     });
                   }});
  cases.push_back(
      {"generations above the bound", kInvalid, "spec.planner.generations", [](auto& s) {
         return Create(s, "big", [](auto& spec) {
           spec.mutable_planner()->set_generations(api::kMaxGenerations + 1);
         });
       }});
  cases.push_back(
      {"waypoints above the bound", kInvalid, "spec.planner.num_waypoints", [](auto& s) {
         return Create(s, "big", [](auto& spec) {
           spec.mutable_planner()->set_num_waypoints(api::kMaxWaypoints + 1);
         });
       }});
  cases.push_back({"too many obstacles in a spec", kInvalid, "spec.obstacles", [](auto& s) {
                     return Create(s, "big", [](auto& spec) {
                       for (int i = 0; i <= api::kMaxObstacles; ++i) {
                         *spec.add_obstacles() = BoxAt(absl::StrCat("o", i), 5, 5, 0.1);
                       }
                     });
                   }});
  cases.push_back(
      {"search area ring of two vertices", kInvalid, "spec.search_areas[0].outer", [](auto& s) {
         return Create(s, "area", [](auto& spec) {
           v1::Ring* ring = spec.add_search_areas()->mutable_outer();
           for (const double v : {0.0, 0.0, 5.0, 5.0}) ring->add_xy_m(v);
         });
       }});
  cases.push_back(
      {"search area beyond the vertex bound", kInvalid, "spec.search_areas", [](auto& s) {
         return Create(s, "area", [](auto& spec) {
           v1::Ring* ring = spec.add_search_areas()->mutable_outer();
           for (int i = 0; i < 2 * api::kMaxAreaVertices + 2; ++i) ring->add_xy_m(1.0);
         });
       }});
  // Far-off obstacles once overflowed the ESDF's voxel indices (found by
  // fuzz/fuzz_requests).
  cases.push_back(
      {"obstacle 1e20 m away", kInvalid, "spec.obstacles[0].box.centre_m.x", [](auto& s) {
         return Create(s, "far", [](auto& spec) {
           spec.mutable_obstacles(0)->mutable_box()->mutable_centre_m()->set_x(1e20);
         });
       }});
  cases.push_back(
      {"cylinder taller than the bound", kInvalid, "add[0].cylinder.height_m", [](auto& s) {
         return Obstacles(s, [](auto& r) {
           auto* c = r.add_add();
           c->set_id("tall");
           c->mutable_cylinder()->set_radius_m(1);
           c->mutable_cylinder()->set_height_m(api::kMaxCoordinateM * 2);
         });
       }});
  cases.push_back({"too many obstacles in a change", kInvalid, "add", [](auto& s) {
                     return Obstacles(s, [](auto& r) {
                       for (int i = 0; i <= api::kMaxObstacles; ++i) {
                         *r.add_add() = BoxAt(absl::StrCat("o", i), 5, 5, 0.1);
                       }
                     });
                   }});
  cases.push_back({"too many boxes", kInvalid, "detections.boxes", [](auto& s) {
                     return Measure(s, [](auto& r) {
                       auto* d = r.mutable_detections();
                       for (int i = 0; i <= api::kMaxBoxes; ++i) {
                         auto* b = d->add_boxes();
                         b->set_x_min_px(1);
                         b->set_y_min_px(1);
                         b->set_x_max_px(2);
                         b->set_y_max_px(2);
                       }
                     });
                   }});
  cases.push_back({"too many labels", kInvalid, "labels.cells", [](auto& s) {
                     return Measure(s, [](auto& r) {
                       r.mutable_labels()->clear_cells();
                       r.mutable_labels()->clear_labels();
                       for (int i = 0; i <= api::kMaxLabels; ++i) {
                         r.mutable_labels()->add_cells(i);
                         r.mutable_labels()->add_labels(0);
                       }
                     });
                   }});
  cases.push_back({"NaN planning budget", kInvalid, "planning_budget_s",
                   [](auto& s) { return Plan(s, [](auto& r) { r.set_planning_budget_s(NAN); }); }});
  cases.push_back({"negative planning budget", kInvalid, "planning_budget_s",
                   [](auto& s) { return Plan(s, [](auto& r) { r.set_planning_budget_s(-1); }); }});
  // The core's own field names never reach the caller.
  cases.push_back({"inside a building, by the API's name", grpc::StatusCode::FAILED_PRECONDITION,
                   "state.position_m:", [](auto& s) {
                     return Plan(s, [](auto& r) {
                       r.mutable_state()->mutable_position_m()->set_x(0);
                       r.mutable_state()->mutable_position_m()->set_y(-2);
                     });
                   }});
  cases.push_back(
      {"too fast, by the API's names", kInvalid, "spec.flight.max_speed_m_s", [](auto& s) {
         return Plan(s, [](auto& r) { r.mutable_state()->mutable_velocity_m_s()->set_x(20); });
       }});
  cases.push_back({"forged page token", kInvalid, "page_token", [](auto& s) {
                     grpc::ClientContext c;
                     v1::ListMissionsRequest r;
                     r.set_page_token(absl::WebSafeBase64Escape("p1.1.0000000000000000"));
                     v1::ListMissionsResponse out;
                     return s.ListMissions(&c, r, &out);
                   }});
}

TEST(BadRequestTest, EachGetsItsCodeAndNamesTheField) {
  InProcessService s;
  const v1::Mission ok = CreateSmall(s.stub(), "ok");
  std::vector<BadCase> cases = Cases();
  AddNonFiniteSpecCases(cases);
  AddLimitCases(cases);
  ASSERT_GE(cases.size(), 107u);
  for (const BadCase& c : cases) {
    const grpc::Status status = c.call(s.stub());
    EXPECT_EQ(status.error_code(), c.code) << c.name << ": " << status.error_message();
    EXPECT_NE(status.error_message().find(c.field), std::string::npos)
        << c.name << ": message \"" << status.error_message() << "\" should name " << c.field;
  }
  // Nothing was half-applied, and the server still serves.
  grpc::ClientContext context;
  v1::GetMissionRequest get;
  get.set_name("missions/ok");
  v1::Mission after;
  ASSERT_TRUE(s.stub().GetMission(&context, get, &after).ok());
  EXPECT_EQ(after.measurements_fused(), 0);
  EXPECT_EQ(after.obstacles_size(), 1);
  EXPECT_DOUBLE_EQ(after.trace(), ok.trace());
  EXPECT_TRUE(Plan(s.stub(), [](auto&) {}).ok());
}

// What an error repeats of the request is short and one line: a 1 MB
// mission_id does not come back as a 1 MB message, and a newline in an id
// cannot start a forged log line.
TEST(BadRequestTest, EchoedInputIsCappedAndEscaped) {
  InProcessService s;
  const std::string huge(1 << 20, 'a');
  for (const std::string& id : {huge, std::string("x\nrpc method=DeleteMission code=OK")}) {
    grpc::ClientContext context;
    v1::CreateMissionRequest request;
    request.set_mission_id(id);
    *request.mutable_spec() = SmallSpec();
    v1::Mission m;
    const grpc::Status status = s.stub().CreateMission(&context, request, &m);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_LT(status.error_message().size(), 200u);
    EXPECT_EQ(status.error_message().find('\n'), std::string::npos);
    EXPECT_NE(status.error_message().find("mission_id"), std::string::npos);
  }
  grpc::ClientContext context;
  v1::GetMissionRequest get;
  get.set_name("missions/" + huge);
  v1::Mission m;
  const grpc::Status status = s.stub().GetMission(&context, get, &m);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_LT(status.error_message().size(), 200u);
  EXPECT_NE(status.error_message().find("(1048585 bytes)"), std::string::npos)
      << status.error_message();
}

// A request_id names one request: its retry gets the first answer, its reuse
// for a different request is refused naming request_id (and changes
// nothing), for every mutation.
TEST(BadRequestTest, AReusedRequestIdWithADifferentRequestIsRefused) {
  InProcessService s;
  const auto create = [&](const std::string& id, const std::string& request_id) {
    grpc::ClientContext context;
    v1::CreateMissionRequest request;
    request.set_mission_id(id);
    request.set_request_id(request_id);
    *request.mutable_spec() = SmallSpec();
    v1::Mission m;
    return s.stub().CreateMission(&context, request, &m);
  };
  const auto expect_refused = [](const grpc::Status& status) {
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_NE(status.error_message().find("request_id"), std::string::npos);
  };
  ASSERT_TRUE(create("a", "c1").ok());
  ASSERT_TRUE(create("a", "c1").ok());  // a retry
  expect_refused(create("b", "c1"));
  ASSERT_TRUE(create("b", "c2").ok());

  const auto measure = [&](double x, v1::AddMeasurementResponse* out) {
    grpc::ClientContext context;
    v1::AddMeasurementRequest request = LabelMeasurement("missions/a", x, 2, 10, 5, 1);
    request.set_request_id("m1");
    return s.stub().AddMeasurement(&context, request, out);
  };
  v1::AddMeasurementResponse first, again;
  ASSERT_TRUE(measure(2, &first).ok());
  expect_refused(measure(-3, &again));
  ASSERT_TRUE(measure(2, &again).ok());
  EXPECT_EQ(again.SerializeAsString(), first.SerializeAsString());
  EXPECT_EQ(again.measurements_fused(), 1);

  const auto obstacles = [&](double x) {
    return Obstacles(s.stub(), [x](v1::UpdateObstaclesRequest& r) {
      r.set_name("missions/a");
      r.set_request_id("o1");
      *r.add_add() = BoxAt("shed", x, -4, 1);
    });
  };
  ASSERT_TRUE(obstacles(3).ok());
  expect_refused(obstacles(5));

  const auto plan = [&](double z) {
    grpc::ClientContext context;
    v1::PlanPathRequest request;
    request.set_name("missions/a");
    request.set_request_id("p1");
    request.mutable_state()->mutable_position_m()->set_x(-4);
    request.mutable_state()->mutable_position_m()->set_y(4);
    request.mutable_state()->mutable_position_m()->set_z(z);
    v1::PlanPathResponse path;
    return s.stub().PlanPath(&context, request, &path);
  };
  ASSERT_TRUE(plan(8).ok());
  expect_refused(plan(9));

  const auto remove = [&](const std::string& name) {
    grpc::ClientContext context;
    v1::DeleteMissionRequest request;
    request.set_name(name);
    request.set_request_id("d1");
    v1::DeleteMissionResponse r;
    return s.stub().DeleteMission(&context, request, &r);
  };
  ASSERT_TRUE(remove("missions/a").ok());
  ASSERT_TRUE(remove("missions/a").ok());  // a retry
  expect_refused(remove("missions/b"));
  EXPECT_EQ(s.registry().size(), 1u);  // b is still there
}

}  // namespace
}  // namespace oaipp::server
