// Writes the seed corpus of the fuzz targets (fuzz/corpus/, committed), made
// from the repository's own examples: the scenario files in
// client/scenarios/ and requests like those of tests/api/convert_test.cc.
//
//   build-fuzz/fuzz/fuzz_make_seeds . fuzz/corpus
//
// fuzz_requests seeds are one byte naming the message type (the MessageKind
// numbers of fuzz_requests.cc) followed by the serialized message;
// fuzz_scenario seeds are JSON files.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "api/mission_config.h"
#include "api/plan.h"
#include "api/spec.h"
#include "core/trajectory/polynomial_trajectory.h"
#include "fuzz/fuzz_specs.h"
#include "oaipp/v1/mission_service.pb.h"
#include "sim/scenario.h"
#include "tests/api/custom_spec.h"

namespace oaipp::fuzz {
namespace {

namespace fs = std::filesystem;

using Kind = MessageKind;

// The scenario files that seed both targets.
constexpr const char* kScenarios[] = {"e1", "e4", "e5", "zurich"};

void WriteFile(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
  if (!out) {
    std::fprintf(stderr, "make_seeds: cannot write %s\n", path.c_str());
    std::exit(1);
  }
}

void WriteSeed(const fs::path& dir, const std::string& name, Kind kind,
               const google::protobuf::Message& message) {
  WriteFile(dir / name, std::string(1, static_cast<char>(kind)) + message.SerializeAsString());
}

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::fprintf(stderr, "make_seeds: cannot read %s\n", path.c_str());
    std::exit(1);
  }
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

using examples::CustomSpec;

void WriteRequestSeeds(const fs::path& root, const fs::path& dir) {
  for (const char* name : kScenarios) {
    absl::StatusOr<v1::Scenario> scenario =
        sim::LoadScenarioFile((root / "client/scenarios" / absl::StrCat(name, ".json")).string());
    if (!scenario.ok()) {
      std::fprintf(stderr, "make_seeds: %s\n", scenario.status().ToString().c_str());
      std::exit(1);
    }
    v1::CreateMissionRequest create;
    create.set_mission_id(name);
    *create.mutable_spec() = scenario->mission();
    create.set_request_id(absl::StrCat("seed-", name));
    WriteSeed(dir, absl::StrCat("create_mission-", name), Kind::kCreateMission, create);
    // The effective spec (every field set) of the same mission.
    absl::StatusOr<api::MissionConfig> config = api::MissionSpecToConfig(scenario->mission());
    if (config.ok()) {
      *create.mutable_spec() = api::ConfigToMissionSpec(*config);
      WriteSeed(dir, absl::StrCat("create_mission-", name, "-effective"), Kind::kCreateMission,
                create);
    }
  }
  v1::CreateMissionRequest create;
  WriteSeed(dir, "create_mission-default", Kind::kCreateMission, create);
  create.set_mission_id("custom");
  *create.mutable_spec() = CustomSpec();
  WriteSeed(dir, "create_mission-custom", Kind::kCreateMission, create);
  create.set_mission_id("small");
  // The fixed mission, which the fuzzer can afford to build.
  *create.mutable_spec() = FixedMissionSpec();
  *create.mutable_spec()->mutable_start()->mutable_position_m() = V(-2, -2, 6);
  WriteSeed(dir, "create_mission-small", Kind::kCreateMission, create);
  create.set_mission_id("small-detector-noise");
  create.mutable_spec()->mutable_sensor()->mutable_detector_noise()->set_p_max(0.9);
  WriteSeed(dir, "create_mission-detector_noise", Kind::kCreateMission, create);
  // The per-mission confirmation options over the detector's rates.
  create.set_mission_id("small-confirmation");
  create.mutable_spec()->mutable_sensor()->mutable_detector_noise()->set_false_positive_rate(0.013);
  v1::PlannerSpec& confirm = *create.mutable_spec()->mutable_planner();
  confirm.set_confirmation_weight(1000);
  confirm.set_confirmation_phase_s(45);
  confirm.set_second_look_weight(1000);
  confirm.set_second_look_sharpness(0.31);
  WriteSeed(dir, "create_mission-confirmation", Kind::kCreateMission, create);

  v1::GetMissionRequest get;
  get.set_name("missions/e1");
  WriteSeed(dir, "get_mission", Kind::kGetMission, get);
  v1::ListMissionsRequest list;
  list.set_page_size(10);
  list.set_page_token("cDEuMy5hYmNkZWY");
  WriteSeed(dir, "list_missions", Kind::kListMissions, list);
  v1::DeleteMissionRequest del;
  del.set_name("missions/e1");
  del.set_request_id("delete-1");
  WriteSeed(dir, "delete_mission", Kind::kDeleteMission, del);

  // Against fuzz_requests.cc's fixed mission: obstacles "tower" and "mast".
  v1::UpdateObstaclesRequest update;
  update.set_name("missions/e1");
  *update.add_add() = BoxObstacle("shed", V(-2, -3, 1), V(2, 1.5, 2), 45);
  v1::Obstacle& pole = *update.add_add();
  pole.set_id("pole");
  *pole.mutable_cylinder()->mutable_centre_m() = V(3, 3, 3);
  pole.mutable_cylinder()->set_radius_m(0.2);
  pole.mutable_cylinder()->set_height_m(6);
  update.add_remove("mast");
  *update.add_replace() = BoxObstacle("tower", V(2, -1, 6), V(2, 2, 12), 0);
  update.set_request_id("obstacles-1");
  WriteSeed(dir, "update_obstacles", Kind::kUpdateObstacles, update);

  v1::AddMeasurementRequest labels;
  labels.set_name("missions/e1");
  labels.set_mission_time_s(12.5);
  *labels.mutable_camera_position_m() = V(0, 0, 8);
  labels.set_camera_yaw_deg(15);
  for (const auto& [cell, label] :
       std::vector<std::pair<int, double>>{{0, 0.0}, {1, 1.0}, {2, 0.5}, {55, 1.0}}) {
    labels.mutable_labels()->add_cells(cell);
    labels.mutable_labels()->add_labels(label);
  }
  labels.set_request_id("measurement-1");
  WriteSeed(dir, "add_measurement-labels", Kind::kAddMeasurement, labels);

  v1::AddMeasurementRequest detections;
  detections.set_name("missions/e1");
  detections.set_mission_time_s(20);
  *detections.mutable_camera_position_m() = V(1, -1, 10);
  v1::ImageDetections& d = *detections.mutable_detections();
  v1::CameraIntrinsics& k = *d.mutable_intrinsics();
  k.set_fx_px(500);
  k.set_fy_px(510);
  k.set_cx_px(320);
  k.set_cy_px(240);
  k.set_width_px(640);
  k.set_height_px(480);
  k.set_k1(-0.05);
  k.set_k2(0.01);
  k.set_p1(0.001);
  k.set_p2(-0.001);
  k.set_k3(0.0005);
  for (const auto& [x0, y0, x1, y1, confidence] :
       std::vector<std::tuple<double, double, double, double, double>>{
           {300, 220, 340, 260, 0.8}, {10, 400, 60, 470, 0.4}, {600, 0, 640, 30, 0.95}}) {
    v1::PixelBox& box = *d.add_boxes();
    box.set_x_min_px(x0);
    box.set_y_min_px(y0);
    box.set_x_max_px(x1);
    box.set_y_max_px(y1);
    box.set_confidence(confidence);
  }
  d.set_min_confidence(0.5);
  detections.set_request_id("measurement-2");
  WriteSeed(dir, "add_measurement-detections", Kind::kAddMeasurement, detections);
  // The default image (480 x 640) of the mission's field of view.
  d.clear_intrinsics();
  d.mutable_boxes(1)->set_y_max_px(600);
  d.mutable_boxes(2)->set_x_max_px(470);
  d.mutable_boxes(2)->set_x_min_px(400);
  detections.set_camera_yaw_deg(-90);
  WriteSeed(dir, "add_measurement-default_image", Kind::kAddMeasurement, detections);

  v1::PlanPathRequest plan;
  plan.set_name("missions/e1");
  v1::UavState& state = *plan.mutable_state();
  *state.mutable_position_m() = V(0, 0, 8);
  *state.mutable_velocity_m_s() = V(1, 0, 0);
  *state.mutable_acceleration_m_s2() = V(0, 0.5, 0);
  state.set_mission_time_s(3);
  plan.set_next_shot_mission_s(6.6);
  plan.set_planning_budget_s(0.5);
  plan.set_request_id("plan-1");
  WriteSeed(dir, "plan_path", Kind::kPlanPath, plan);

  v1::GetMapRequest map;
  map.set_name("missions/e1");
  map.set_include_cells(true);
  map.set_include_png(true);
  WriteSeed(dir, "get_map", Kind::kGetMap, map);
  v1::WatchMissionRequest watch;
  watch.set_name("missions/e1");
  WriteSeed(dir, "watch_mission", Kind::kWatchMission, watch);

  // A two-segment path as the server writes it: climb, then cruise.
  PolynomialTrajectory::SegmentCoefficients climb =
      PolynomialTrajectory::SegmentCoefficients::Zero();
  climb.row(0) << 0, 0, 8;
  climb.row(1) << 1, 0.5, 0;
  climb.row(2) << 0, 0, 0.25;
  PolynomialTrajectory::SegmentCoefficients cruise =
      PolynomialTrajectory::SegmentCoefficients::Zero();
  cruise.row(0) << 2, 1, 9;
  cruise.row(1) << 1, 0.5, 1;
  cruise.row(3) << -0.01, 0.02, -0.03;
  absl::StatusOr<PolynomialTrajectory> trajectory =
      PolynomialTrajectory::FromCoefficients({2.0, 3.0}, {climb, cruise});
  if (!trajectory.ok()) {
    std::fprintf(stderr, "make_seeds: %s\n", trajectory.status().ToString().c_str());
    std::exit(1);
  }
  PlannedPath path{.trajectory = *trajectory};
  path.control_waypoints_W = {Vec3(0, 0, 8), Vec3(2, 1, 9), Vec3(5, 2.5, 12)};
  path.measurement_poses = {
      {.t_s = 1.5, .mission_time_s = 4.5, .position_W = Vec3(1.5, 0.75, 8.6)}};
  path.objective = 0.8;
  path.information = 4.0;
  path.collision_free = true;
  path.next_shot_mission_s = 11.2;
  path.stats = {.evaluations = 540,
                .generations = 45,
                .wall_time_s = 0.3,
                .stop_reason = "evaluation_budget",
                .initial_objective = 0.6};
  v1::PlanPathResponse response;
  api::PlannedPathToProto(path, &response);
  WriteSeed(dir, "plan_path_response", Kind::kPlanPathResponse, response);

  v1::ExportPathRequest export_path;
  export_path.set_name("missions/m1");
  *export_path.mutable_path() = response;
  export_path.set_setpoint_rate_hz(20.0);
  export_path.set_waypoint_tolerance_m(0.2);
  export_path.set_max_items(32);
  WriteSeed(dir, "export_path", Kind::kExportPath, export_path);
}

void WriteScenarioSeeds(const fs::path& root, const fs::path& dir) {
  for (const char* name : kScenarios) {
    WriteFile(dir / absl::StrCat(name, ".json"),
              ReadFile(root / "client/scenarios" / absl::StrCat(name, ".json")));
  }
  // Small enough for fuzz_scenario.cc's size guards, with every field of
  // Scenario and both obstacle shapes.
  WriteFile(dir / "small.json", R"({
  "name": "small",
  "mission": {
    "field": {"x_min_m": -4, "y_min_m": -4, "x_max_m": 4, "y_max_m": 4, "resolution_m": 1},
    "flight": {"min_altitude_m": 2, "max_altitude_m": 10, "esdf_voxel_m": 0.5,
               "esdf_truncation_m": 1},
    "obstacles": [
      {"id": "hut", "box": {"centre_m": {"x": 2, "y": 2, "z": 1.5},
                            "size_m": {"x": 2, "y": 3, "z": 3}, "yaw_deg": 10}},
      {"id": "pole", "cylinder": {"centre_m": {"x": -2, "y": -2, "z": 4}, "radius_m": 0.3,
                                  "height_m": 8}}
    ],
    "start": {"position_m": {"x": 0, "y": 0, "z": 6}},
    "planner": {"kind": "PLANNER_KIND_LAWNMOWER", "seed": 3, "lawnmowerStartCorner": 1},
    "budgetS": 60
  },
  "targets": [
    {"id": "p1", "x_min_m": 0.5, "y_min_m": -3, "x_max_m": 1.25, "y_max_m": -1},
    {"x_min_m": -3.5, "y_min_m": 1, "x_max_m": -2.75, "y_max_m": 3}
  ],
  "detector": {"p_max": 0.9, "h_best_m": 8, "width_m": 5, "fp_per_image_at_10m": 1.5,
               "min_confidence": 0.4},
  "seed": "7",
  "send_cell_labels": true,
  "planning_budget_s": 0.25
}
)");
  WriteFile(dir / "empty.json", "{}\n");
}

}  // namespace
}  // namespace oaipp::fuzz

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s REPOSITORY_ROOT CORPUS_DIR\n", argv[0]);
    return 2;
  }
  namespace fs = std::filesystem;
  const fs::path root = argv[1];
  const fs::path corpus = argv[2];
  const fs::path requests = corpus / "fuzz_requests";
  const fs::path scenarios = corpus / "fuzz_scenario";
  fs::create_directories(requests);
  fs::create_directories(scenarios);
  oaipp::fuzz::WriteRequestSeeds(root, requests);
  oaipp::fuzz::WriteScenarioSeeds(root, scenarios);
  return 0;
}
