// libFuzzer target: one message of oaipp.v1.MissionService as the server
// receives it, through every check and conversion in api/ that the server
// applies to it (server/service.cc), plus the cheap mission-side steps that
// follow them (server/mission.cc: environment, grid, map).
//
// Input: byte 0 picks the message type (MessageKind, modulo its count); the
// other bytes are the message's wire encoding. Input that does not parse is
// dropped.
//
// What aborts (so libFuzzer keeps the input as a crash):
//  - any sanitizer report;
//  - an error whose code the function does not document, or whose message
//    does not survive api::SafeMessage's bounds (fuzz_util.h);
//  - a round trip that does not come back: spec -> config -> spec -> config
//    must give the same config field for field (yaws to a few ulps, as
//    api/spec.h documents), and likewise obstacle changes, measurements, UAV
//    states and planned paths;
//  - a config that MissionSpecToConfig accepted but that the core then
//    refuses (grid, planner, intrinsics, environment), or a map update that
//    raises uncertainty or leaves a non-finite value.
//
// Size guards: the conversions cap what a request may ask for, but the
// mission-side steps still cost up to 800 MB (10'000 cells) and 200 million
// ESDF voxels for a valid spec. To keep every input in milliseconds, the
// environment is built only when its ESDF has at most kMaxFuzzVoxels voxels
// and voxels x (obstacles + 1) stays under kMaxFuzzVoxelWork (counted before
// anything is allocated, as Esdf::Create counts them), and the map only for
// fields of at most kMaxFuzzCells cells. Measurements and obstacle changes
// go to a fixed small mission (FixedMission) built once.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "api/export.h"
#include "api/geodetic.h"
#include "api/geometry.h"
#include "api/measurement.h"
#include "api/mission_config.h"
#include "api/plan.h"
#include "api/spec.h"
#include "api/status.h"
#include "core/environment/environment.h"
#include "core/mapping/camera.h"
#include "core/mapping/detection_projection.h"
#include "core/mapping/field_grid.h"
#include "core/mapping/gp_map.h"
#include "core/planning/planners.h"
#include "fuzz/fuzz_specs.h"
#include "fuzz/fuzz_util.h"
#include "google/protobuf/stubs/logging.h"
#include "google/protobuf/util/field_comparator.h"
#include "google/protobuf/util/message_differencer.h"
#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::fuzz {
namespace {

using absl::StatusCode;
using api::MeasurementInput;
using api::MissionConfig;
using google::protobuf::util::DefaultFieldComparator;
using google::protobuf::util::MessageDifferencer;

constexpr std::int64_t kMaxFuzzVoxels = 1 << 17;
constexpr std::int64_t kMaxFuzzVoxelWork = 1 << 21;
constexpr int kMaxFuzzCells = 256;
// Obstacles added or replaced in one change that FixedMission applies (each
// one recomputes the ESDF around it).
constexpr std::size_t kMaxFuzzChangedObstacles = 32;
// Longest trajectory PlannedPathToProto samples here (10 Hz): 6000 samples.
constexpr double kMaxFuzzTrajectory_s = 600.0;

// ---------------------------------------------------------------------------
// Field-for-field comparison (MissionConfig has no operator==).

std::string ObstacleDifference(const Obstacle& a, const Obstacle& b) {
  if (a.id != b.id) return "id";
  if (a.shape.index() != b.shape.index()) return "shape kind";
  if (const Box* x = std::get_if<Box>(&a.shape)) {
    const Box& y = std::get<Box>(b.shape);
    if (x->centre_W != y.centre_W) return "box.centre_W";
    if (x->size_m != y.size_m) return "box.size_m";
    if (!NearlyEqualAngle(x->yaw_rad, y.yaw_rad)) {
      return absl::StrCat("box.yaw_rad ", x->yaw_rad, " vs ", y.yaw_rad);
    }
    return "";
  }
  if (const Prism* x = std::get_if<Prism>(&a.shape)) {
    const Prism& y = std::get<Prism>(b.shape);
    if (x->footprint() != y.footprint()) return "prism.footprint";
    if (x->base_m() != y.base_m()) return "prism.base_m";
    if (x->top_m() != y.top_m()) return "prism.top_m";
    return "";
  }
  const Cylinder& x = std::get<Cylinder>(a.shape);
  const Cylinder& y = std::get<Cylinder>(b.shape);
  if (x.centre_W != y.centre_W) return "cylinder.centre_W";
  if (x.radius_m != y.radius_m) return "cylinder.radius_m";
  if (x.height_m != y.height_m) return "cylinder.height_m";
  return "";
}

std::string ObstaclesDifference(const std::vector<Obstacle>& a, const std::vector<Obstacle>& b) {
  if (a.size() != b.size()) return absl::StrCat("count ", a.size(), " vs ", b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (std::string d = ObstacleDifference(a[i], b[i]); !d.empty()) {
      return absl::StrCat("[", i, "].", d);
    }
  }
  return "";
}

std::string StateDifference(const UavState& a, const UavState& b) {
  if (a.position_W != b.position_W) return "position_W";
  if (a.velocity_W_m_s != b.velocity_W_m_s) return "velocity_W_m_s";
  if (a.accel_W_m_s2 != b.accel_W_m_s2) return "accel_W_m_s2";
  if (a.mission_time_s != b.mission_time_s) return "mission_time_s";
  return "";
}

// The first field in which the configs differ, "" when they agree. Doubles
// compare with ==, so a NaN that validation let through shows up here too.
std::string ConfigDifference(const MissionConfig& a, const MissionConfig& b) {
#define OAIPP_FUZZ_SAME(field) \
  if (!(a.field == b.field)) return #field
  OAIPP_FUZZ_SAME(preset);
  OAIPP_FUZZ_SAME(field_min_W);
  OAIPP_FUZZ_SAME(field_max_W);
  OAIPP_FUZZ_SAME(resolution_m);
  OAIPP_FUZZ_SAME(gp.length_scale_m);
  OAIPP_FUZZ_SAME(gp.signal_var);
  OAIPP_FUZZ_SAME(gp.noise_var);
  OAIPP_FUZZ_SAME(gp.prior_mean);
  OAIPP_FUZZ_SAME(prior_map_units);
  if ((a.prior_map == nullptr) != (b.prior_map == nullptr) ||
      (a.prior_map != nullptr && *a.prior_map != *b.prior_map)) {
    return "prior_map";
  }
  OAIPP_FUZZ_SAME(camera.fov_x_deg);
  OAIPP_FUZZ_SAME(camera.fov_y_deg);
  OAIPP_FUZZ_SAME(camera.rate_hz);
  OAIPP_FUZZ_SAME(noise.a_var);
  OAIPP_FUZZ_SAME(noise.b_per_m);
  OAIPP_FUZZ_SAME(noise.detector);
  OAIPP_FUZZ_SAME(min_altitude_m);
  OAIPP_FUZZ_SAME(max_altitude_m);
  OAIPP_FUZZ_SAME(esdf.voxel_size_m);
  OAIPP_FUZZ_SAME(esdf.truncation_m);
  OAIPP_FUZZ_SAME(esdf.max_voxels);
  OAIPP_FUZZ_SAME(planner.kind);
  OAIPP_FUZZ_SAME(planner.common.limits.dynamics.max_speed_m_s);
  OAIPP_FUZZ_SAME(planner.common.limits.dynamics.max_accel_m_s2);
  OAIPP_FUZZ_SAME(planner.common.limits.uav_radius_m);
  OAIPP_FUZZ_SAME(planner.common.limits.tracking_error_m);
  OAIPP_FUZZ_SAME(planner.common.limits.obstacle_rule);
  OAIPP_FUZZ_SAME(planner.common.limits.collision_sample_rate_hz);
  OAIPP_FUZZ_SAME(planner.common.limits.exact_check_spacing_m);
  OAIPP_FUZZ_SAME(planner.common.information.kind);
  OAIPP_FUZZ_SAME(planner.common.information.kappa);
  OAIPP_FUZZ_SAME(planner.common.information.h_opt_m);
  OAIPP_FUZZ_SAME(planner.common.information.sigma1_m);
  OAIPP_FUZZ_SAME(planner.common.information.h_sat_m);
  OAIPP_FUZZ_SAME(planner.common.information.confirmation_weight);
  OAIPP_FUZZ_SAME(planner.common.information.decision_threshold);
  OAIPP_FUZZ_SAME(planner.common.information.confirmation_phase_s);
  OAIPP_FUZZ_SAME(planner.common.information.confirmation_phase_weight);
  OAIPP_FUZZ_SAME(planner.common.information.ambiguity_margin);
  OAIPP_FUZZ_SAME(planner.common.information.second_look_weight);
  OAIPP_FUZZ_SAME(planner.common.information.second_look_sharpness);
  OAIPP_FUZZ_SAME(planner.common.information.confirmation_preposterior);
  OAIPP_FUZZ_SAME(planner.common.weights.k1);
  OAIPP_FUZZ_SAME(planner.common.weights.k2);
  OAIPP_FUZZ_SAME(planner.common.weights.min_flight_time_s);
  OAIPP_FUZZ_SAME(planner.common.seed);
  OAIPP_FUZZ_SAME(planner.oaipp.num_waypoints);
  OAIPP_FUZZ_SAME(planner.oaipp.greedy_altitudes_m);
  OAIPP_FUZZ_SAME(planner.oaipp.greedy_candidates_per_layer);
  OAIPP_FUZZ_SAME(planner.oaipp.population);
  OAIPP_FUZZ_SAME(planner.oaipp.generations);
  OAIPP_FUZZ_SAME(planner.oaipp.stall_generations);
  OAIPP_FUZZ_SAME(planner.oaipp.stall_tolerance);
  OAIPP_FUZZ_SAME(planner.oaipp.step_m);
  OAIPP_FUZZ_SAME(planner.oaipp.refine);
  OAIPP_FUZZ_SAME(planner.oaipp.exact_check_candidates);
  OAIPP_FUZZ_SAME(planner.lawnmower.altitude_m);
  OAIPP_FUZZ_SAME(planner.lawnmower.start_corner);
  OAIPP_FUZZ_SAME(planner.lawnmower.points_per_plan);
  OAIPP_FUZZ_SAME(planner.lawnmower.detour_margin_m);
  OAIPP_FUZZ_SAME(planner.random.max_attempts);
  OAIPP_FUZZ_SAME(budget_s);
  OAIPP_FUZZ_SAME(min_separation_m);
  OAIPP_FUZZ_SAME(silent_after_s);
  if (a.geo_origin != b.geo_origin) return "geo_origin";
#undef OAIPP_FUZZ_SAME
  if (std::string d = ObstaclesDifference(a.obstacles, b.obstacles); !d.empty()) {
    return absl::StrCat("obstacles", d);
  }
  if (std::string d = StateDifference(a.start, b.start); !d.empty()) {
    return absl::StrCat("start.", d);
  }
  return "";
}

// Box yaws of a spec set to 0 once checked to a few ulps, so that the rest
// of two specs can be compared exactly.
bool ClearMatchingYaws(v1::MissionSpec& a, v1::MissionSpec& b) {
  if (a.obstacles_size() != b.obstacles_size()) return false;
  for (int i = 0; i < a.obstacles_size(); ++i) {
    v1::Obstacle& x = *a.mutable_obstacles(i);
    v1::Obstacle& y = *b.mutable_obstacles(i);
    if (!x.has_box() || !y.has_box()) continue;
    if (!NearlyEqualAngle(x.box().yaw_deg(), y.box().yaw_deg())) return false;
    x.mutable_box()->set_yaw_deg(0);
    y.mutable_box()->set_yaw_deg(0);
  }
  return true;
}

// ---------------------------------------------------------------------------
// The mission that measurements and obstacle changes are applied to: 10 x 10
// cells of 1 m, 2..12 m altitude, a 0.5 m ESDF (13'824 voxels), a yawed box
// "tower" and a cylinder "mast" (the ids the seed corpus uses).

struct FixedMission {
  MissionConfig config;
  std::unique_ptr<Environment> env;
  std::optional<FieldGrid> grid;
  std::unique_ptr<GpMap> map;
};

FixedMission MakeFixedMission() {
  const v1::MissionSpec spec = FixedMissionSpec();
  FixedMission m;
  absl::StatusOr<MissionConfig> config = api::MissionSpecToConfig(spec);
  OAIPP_FUZZ_CHECK(config.ok(), config.status().ToString());
  m.config = *std::move(config);
  absl::StatusOr<Environment> env = m.config.MakeEnvironment();
  OAIPP_FUZZ_CHECK(env.ok(), env.status().ToString());
  m.env = std::make_unique<Environment>(*std::move(env));
  absl::StatusOr<FieldGrid> grid = m.config.MakeGrid();
  OAIPP_FUZZ_CHECK(grid.ok(), grid.status().ToString());
  m.grid = *grid;
  absl::StatusOr<GpMap> map = GpMap::Create(*m.grid, m.config.gp);
  OAIPP_FUZZ_CHECK(map.ok(), map.status().ToString());
  m.map = std::make_unique<GpMap>(*std::move(map));
  return m;
}

const FixedMission& Fixed() {
  static const FixedMission* const mission = new FixedMission(MakeFixedMission());
  return *mission;
}

// ---------------------------------------------------------------------------
// One function per message kind.

// What the server does with a mission id, name or request_id it refuses:
// repeat it through api::EchoInput.
void CheckEchoed(absl::string_view a, absl::string_view b = {}) {
  CheckEchoInput(a);
  if (!b.empty()) CheckEchoInput(b);
}

// CreateMission: MissionSpecToConfig, then what Mission::Create builds.
void CreateMission(const v1::CreateMissionRequest& request) {
  CheckEchoed(request.mission_id(), request.request_id());
  absl::StatusOr<MissionConfig> config = api::MissionSpecToConfig(request.spec());
  CheckError(config.status(), {StatusCode::kInvalidArgument, StatusCode::kResourceExhausted},
             "MissionSpecToConfig");
  if (!config.ok()) return;
  const MissionConfig& c = *config;

  // The effective spec (what GetMission shows) converts to the same config,
  // and is itself a fixed point.
  v1::MissionSpec effective = api::ConfigToMissionSpec(c);
  absl::StatusOr<MissionConfig> again = api::MissionSpecToConfig(effective);
  OAIPP_FUZZ_CHECK(again.ok(),
                   absl::StrCat("the effective spec is refused: ", again.status().ToString()));
  const std::string difference = ConfigDifference(c, *again);
  OAIPP_FUZZ_CHECK(difference.empty(), absl::StrCat("spec round trip changed ", difference));
  v1::MissionSpec twice = api::ConfigToMissionSpec(*again);
  OAIPP_FUZZ_CHECK(ClearMatchingYaws(effective, twice), "effective spec yaws");
  OAIPP_FUZZ_CHECK(MessageDifferencer::Equals(effective, twice),
                   "the effective spec is not a fixed point");
  absl::StatusOr<PlannerKind> kind =
      api::PlannerKindFromProto(api::PlannerKindToProto(c.planner.kind));
  OAIPP_FUZZ_CHECK(kind.ok() && *kind == c.planner.kind, "PlannerKind round trip");

  // Validated, so the core must accept it.
  absl::StatusOr<FieldGrid> grid = c.MakeGrid();
  OAIPP_FUZZ_CHECK(grid.ok(), absl::StrCat("MakeGrid: ", grid.status().ToString()));
  absl::StatusOr<CameraIntrinsics> intrinsics = c.DefaultIntrinsics();
  OAIPP_FUZZ_CHECK(intrinsics.ok(),
                   absl::StrCat("DefaultIntrinsics: ", intrinsics.status().ToString()));
  OAIPP_FUZZ_CHECK(intrinsics->Validate().ok(), "DefaultIntrinsics gave invalid intrinsics");
  absl::StatusOr<std::unique_ptr<Planner>> planner = MakePlanner(c.planner);
  OAIPP_FUZZ_CHECK(planner.ok(), absl::StrCat("MakePlanner: ", planner.status().ToString()));

  const std::int64_t voxels = Esdf::VoxelCount(c.FlightVolume(), c.esdf);
  if (voxels > kMaxFuzzVoxels ||
      voxels * static_cast<std::int64_t>(c.obstacles.size() + 1) > kMaxFuzzVoxelWork) {
    return;
  }
  absl::StatusOr<Environment> env = c.MakeEnvironment();
  OAIPP_FUZZ_CHECK(env.ok(), absl::StrCat("MakeEnvironment: ", env.status().ToString()));
  // Mission::Create's start clearance check.
  const double clearance = env->SignedDistance(c.start.position_W);
  OAIPP_FUZZ_CHECK(!std::isnan(clearance), "start clearance is NaN");
  if (grid->num_cells() > kMaxFuzzCells) return;
  absl::StatusOr<GpMap> map = GpMap::Create(*grid, c.gp);
  CheckError(map.status(), {StatusCode::kInvalidArgument}, "GpMap::Create");
  if (!map.ok()) return;
  const double prior_trace = map->Trace();
  const std::vector<int> covered =
      grid->CellsUnderObstacles([&](const Vec3& p_W) { return env->IsInsideObstacle(p_W); });
  const absl::Status fused = map->FuseNearCertainZeros(covered);
  CheckError(fused, {StatusCode::kInvalidArgument}, "FuseNearCertainZeros");
  if (std::isfinite(prior_trace)) {
    OAIPP_FUZZ_CHECK(map->Trace() <= prior_trace * (1 + 1e-9) + 1e-12,
                     "fusing covered cells raised Tr(P)");
  }
}

// UpdateObstacles: ObstacleChangeFromProto, its round trip, and the change
// applied to FixedMission's environment.
void UpdateObstacles(const v1::UpdateObstaclesRequest& request) {
  CheckEchoed(request.name(), request.request_id());
  absl::StatusOr<ObstacleChange> change = api::ObstacleChangeFromProto(request);
  CheckError(change.status(), {StatusCode::kInvalidArgument}, "ObstacleChangeFromProto");
  if (!change.ok()) return;

  v1::UpdateObstaclesRequest back;
  for (const Obstacle& o : change->add) *back.add_add() = api::ObstacleToProto(o);
  for (const std::string& id : change->remove) back.add_remove(id);
  for (const Obstacle& o : change->replace) *back.add_replace() = api::ObstacleToProto(o);
  absl::StatusOr<ObstacleChange> again = api::ObstacleChangeFromProto(back);
  OAIPP_FUZZ_CHECK(again.ok(),
                   absl::StrCat("change round trip refused: ", again.status().ToString()));
  std::string d = ObstaclesDifference(change->add, again->add);
  OAIPP_FUZZ_CHECK(d.empty(), absl::StrCat("change round trip: add", d));
  d = ObstaclesDifference(change->replace, again->replace);
  OAIPP_FUZZ_CHECK(d.empty(), absl::StrCat("change round trip: replace", d));
  OAIPP_FUZZ_CHECK(change->remove == again->remove, "change round trip: remove");

  if (change->add.size() + change->replace.size() > kMaxFuzzChangedObstacles) return;
  const FixedMission& m = Fixed();
  Environment env = m.env->Clone();
  const std::size_t before = env.obstacles().size();
  const absl::Status applied = env.Apply(*change);
  CheckError(applied,
             {StatusCode::kInvalidArgument, StatusCode::kNotFound, StatusCode::kAlreadyExists},
             "Environment::Apply");
  if (!applied.ok()) return;
  OAIPP_FUZZ_CHECK(env.obstacles().size() == before + change->add.size() - change->remove.size(),
                   "obstacle count after the change");
  for (const Obstacle& o : change->add) {
    OAIPP_FUZZ_CHECK(env.obstacles().contains(o.id), "an added obstacle is missing");
  }
  for (const std::string& id : change->remove) {
    OAIPP_FUZZ_CHECK(!env.obstacles().contains(id), "a removed obstacle is still there");
  }
  OAIPP_FUZZ_CHECK(!std::isnan(env.SignedDistance(m.config.start.position_W)),
                   "signed distance is NaN after the change");
}

std::string MeasurementDifference(const MeasurementInput& a, const MeasurementInput& b) {
  if (a.mission_time_s != b.mission_time_s) return "mission_time_s";
  if (a.pose.p_WC != b.pose.p_WC) return "pose.p_WC";
  if (!NearlyEqualAngle(a.pose.yaw_rad, b.pose.yaw_rad)) {
    return absl::StrCat("pose.yaw_rad ", a.pose.yaw_rad, " vs ", b.pose.yaw_rad);
  }
  if (a.labels.has_value() != b.labels.has_value()) return "labels set";
  if (a.labels.has_value()) {
    if (a.labels->cells != b.labels->cells) return "labels.cells";
    if (a.labels->labels != b.labels->labels) return "labels.labels";
  }
  if (a.detections.has_value() != b.detections.has_value()) return "detections set";
  if (!a.detections.has_value()) return "";
  const MeasurementInput::Detections& x = *a.detections;
  const MeasurementInput::Detections& y = *b.detections;
  if (x.min_confidence != y.min_confidence) return "detections.min_confidence";
  if (x.intrinsics.has_value() != y.intrinsics.has_value()) return "detections.intrinsics set";
  if (x.intrinsics.has_value()) {
    const CameraIntrinsics& k = *x.intrinsics;
    const CameraIntrinsics& l = *y.intrinsics;
    if (k.fx_px != l.fx_px || k.fy_px != l.fy_px || k.cx_px != l.cx_px || k.cy_px != l.cy_px ||
        k.width_px != l.width_px || k.height_px != l.height_px || k.k1 != l.k1 || k.k2 != l.k2 ||
        k.p1 != l.p1 || k.p2 != l.p2 || k.k3 != l.k3) {
      return "detections.intrinsics";
    }
  }
  if (x.boxes.size() != y.boxes.size()) return "detections.boxes count";
  for (std::size_t i = 0; i < x.boxes.size(); ++i) {
    const PixelBox& p = x.boxes[i];
    const PixelBox& q = y.boxes[i];
    if (p.x_min_px != q.x_min_px || p.y_min_px != q.y_min_px || p.x_max_px != q.x_max_px ||
        p.y_max_px != q.y_max_px || p.confidence != q.confidence) {
      return absl::StrCat("detections.boxes[", i, "]");
    }
  }
  return "";
}

// AddMeasurement: MeasurementFromProto, its round trip through
// MeasurementToProto, then Mission::PrepareMeasurement's steps and the map
// update on FixedMission.
void AddMeasurement(const v1::AddMeasurementRequest& request) {
  CheckEchoed(request.name(), request.request_id());
  absl::StatusOr<MeasurementInput> input = api::MeasurementFromProto(request);
  CheckError(input.status(), {StatusCode::kInvalidArgument}, "MeasurementFromProto");
  if (!input.ok()) return;
  OAIPP_FUZZ_CHECK(input->labels.has_value() != input->detections.has_value(),
                   "exactly one of labels and detections");

  v1::AddMeasurementRequest back;
  api::MeasurementToProto(*input, &back);
  absl::StatusOr<MeasurementInput> again = api::MeasurementFromProto(back);
  OAIPP_FUZZ_CHECK(again.ok(),
                   absl::StrCat("measurement round trip refused: ", again.status().ToString()));
  const std::string difference = MeasurementDifference(*input, *again);
  OAIPP_FUZZ_CHECK(difference.empty(), absl::StrCat("measurement round trip: ", difference));

  const FixedMission& m = Fixed();
  const FieldGrid& grid = *m.grid;
  const Vec3& p = input->pose.p_WC;
  if (!m.env->flight_volume().Contains(p, 1e-6)) return;
  CellLabels labels;
  if (input->labels.has_value()) {
    for (const int cell : input->labels->cells) {
      if (!grid.IsValidCell(cell)) return;
    }
    labels = *input->labels;
  } else {
    CameraIntrinsics intrinsics;
    if (input->detections->intrinsics.has_value()) {
      intrinsics = *input->detections->intrinsics;
    } else {
      absl::StatusOr<CameraIntrinsics> k = m.config.DefaultIntrinsics();
      OAIPP_FUZZ_CHECK(k.ok(), k.status().ToString());
      intrinsics = *k;
    }
    absl::StatusOr<CellLabels> projected =
        DetectionsToLabels(grid, intrinsics, input->pose, input->detections->boxes,
                           input->detections->min_confidence, m.env.get());
    CheckError(projected.status(), {StatusCode::kInvalidArgument}, "DetectionsToLabels");
    if (!projected.ok()) return;
    labels = *std::move(projected);
    OAIPP_FUZZ_CHECK(labels.cells.size() == labels.labels.size(), "projected label count");
    for (const int cell : labels.cells) {
      OAIPP_FUZZ_CHECK(grid.IsValidCell(cell), absl::StrCat("projected cell ", cell));
    }
  }
  absl::StatusOr<std::vector<CellObservation>> observations =
      LabelsToObservations(grid, m.config.noise, p.z(), labels.cells, labels.labels);
  CheckError(observations.status(), {StatusCode::kInvalidArgument}, "LabelsToObservations");
  if (!observations.ok()) return;
  GpMap map = m.map->Clone();
  const double before = map.Trace();
  const absl::Status updated = map.Update(*observations);
  // Internal would mean S lost positive definiteness, which the map
  // documents as impossible.
  CheckError(updated, {StatusCode::kInvalidArgument}, "GpMap::Update");
  if (!updated.ok()) return;
  OAIPP_FUZZ_CHECK(std::isfinite(map.Trace()) && map.Trace() <= before * (1 + 1e-9) + 1e-12,
                   absl::StrCat("Tr(P) went from ", before, " to ", map.Trace()));
  OAIPP_FUZZ_CHECK(map.Mean().allFinite(), "a map mean is not finite");
}

// PlanPath: UavStateFromProto and its round trip (the plan itself is out of
// reach of a fuzzer's time budget).
void PlanPath(const v1::PlanPathRequest& request) {
  CheckEchoed(request.name(), request.request_id());
  if (!request.has_state()) return;
  absl::StatusOr<UavState> state = api::UavStateFromProto(request.state(), "state");
  CheckError(state.status(), {StatusCode::kInvalidArgument}, "UavStateFromProto");
  if (!state.ok()) return;
  absl::StatusOr<UavState> again = api::UavStateFromProto(api::UavStateToProto(*state), "state");
  OAIPP_FUZZ_CHECK(again.ok(),
                   absl::StrCat("state round trip refused: ", again.status().ToString()));
  const std::string difference = StateDifference(*state, *again);
  OAIPP_FUZZ_CHECK(difference.empty(), absl::StrCat("state round trip: ", difference));
  const Vec3 p = api::FromProto(api::ToProto(state->position_W));
  OAIPP_FUZZ_CHECK(p == state->position_W, "Vector3 round trip");
  const FixedMission& m = Fixed();
  if (m.env->flight_volume().Contains(state->position_W)) {
    OAIPP_FUZZ_CHECK(!std::isnan(m.env->SignedDistance(state->position_W)),
                     "signed distance is NaN");
  }
}

double TotalDuration(const v1::Trajectory& trajectory) {
  double total = 0.0;
  for (const v1::PolynomialSegment& s : trajectory.segments()) total += s.duration_s();
  return total;
}

// A stored first answer read back: PlannedPathFromProto. Whatever
// PlannedPathToProto then writes is itself a stored answer, so reading that
// back and writing it again must give it unchanged (api/plan.h).
void PlanPathResponse(const v1::PlanPathResponse& response) {
  absl::StatusOr<PlannedPath> path = api::PlannedPathFromProto(response);
  CheckError(path.status(), {StatusCode::kInvalidArgument}, "PlannedPathFromProto");
  if (!path.ok()) return;
  if (!(TotalDuration(response.trajectory()) <= kMaxFuzzTrajectory_s)) return;
  v1::PlanPathResponse first;
  api::PlannedPathToProto(*path, &first);
  absl::StatusOr<PlannedPath> read_back = api::PlannedPathFromProto(first);
  OAIPP_FUZZ_CHECK(read_back.ok(),
                   absl::StrCat("a written answer is refused: ", read_back.status().ToString()));
  v1::PlanPathResponse second;
  api::PlannedPathToProto(*read_back, &second);
  // Samples of a polynomial that overflows are NaN on both sides.
  DefaultFieldComparator comparator;
  comparator.set_treat_nan_as_equal(true);
  MessageDifferencer differencer;
  differencer.set_field_comparator(&comparator);
  std::string report;
  differencer.ReportDifferencesToString(&report);
  OAIPP_FUZZ_CHECK(differencer.Compare(first, second),
                   absl::StrCat("written, read and written again differs: ", report));
}

// ExportPath: the options, then the export of the path on FixedMission with
// a geo_origin (so that all three forms are built). Work grows with the
// path's length and max_items; both are capped here to keep inputs fast.
void ExportPath(const v1::ExportPathRequest& request) {
  CheckEchoed(request.name());
  absl::StatusOr<api::ExportOptions> options = api::ExportOptionsFromProto(request);
  CheckError(options.status(), {StatusCode::kInvalidArgument}, "ExportOptionsFromProto");
  if (!options.ok()) return;
  if (!(TotalDuration(request.path().trajectory()) <= 30.0) || options->max_items > 64 ||
      options->setpoint_rate_hz > 100.0) {
    return;
  }
  MissionConfig config = Fixed().config;
  config.geo_origin = api::GeoPoint{47.397742, 8.545594, 488.0};
  absl::StatusOr<v1::ExportPathResponse> out =
      api::ExportPath(config, config.obstacles, request.path(), *options);
  CheckError(out.status(), {StatusCode::kInvalidArgument, StatusCode::kFailedPrecondition},
             "ExportPath");
  if (!out.ok()) return;
  OAIPP_FUZZ_CHECK(out->mission_items_size() <= options->max_items,
                   absl::StrCat(out->mission_items_size(), " items, more than max_items"));
  OAIPP_FUZZ_CHECK(out->mission_items_size() >= 2, "fewer than two mission items");
  OAIPP_FUZZ_CHECK(out->setpoints_size() >= 2, "fewer than two setpoints");
  OAIPP_FUZZ_CHECK(!out->qgc_plan_json().empty(), "no .plan with a geo_origin");
}

void Run(MessageKind kind, const std::uint8_t* data, std::size_t size) {
  const int n = static_cast<int>(size);
  switch (kind) {
    case MessageKind::kCreateMission: {
      v1::CreateMissionRequest m;
      if (m.ParseFromArray(data, n)) CreateMission(m);
      return;
    }
    case MessageKind::kGetMission: {
      v1::GetMissionRequest m;
      if (m.ParseFromArray(data, n)) CheckEchoed(m.name());
      return;
    }
    case MessageKind::kListMissions: {
      v1::ListMissionsRequest m;
      if (m.ParseFromArray(data, n)) CheckEchoed(m.page_token());
      return;
    }
    case MessageKind::kDeleteMission: {
      v1::DeleteMissionRequest m;
      if (m.ParseFromArray(data, n)) CheckEchoed(m.name(), m.request_id());
      return;
    }
    case MessageKind::kUpdateObstacles: {
      v1::UpdateObstaclesRequest m;
      if (m.ParseFromArray(data, n)) UpdateObstacles(m);
      return;
    }
    case MessageKind::kAddMeasurement: {
      v1::AddMeasurementRequest m;
      if (m.ParseFromArray(data, n)) AddMeasurement(m);
      return;
    }
    case MessageKind::kPlanPath: {
      v1::PlanPathRequest m;
      if (m.ParseFromArray(data, n)) PlanPath(m);
      return;
    }
    case MessageKind::kGetMap: {
      v1::GetMapRequest m;
      if (m.ParseFromArray(data, n)) CheckEchoed(m.name());
      return;
    }
    case MessageKind::kWatchMission: {
      v1::WatchMissionRequest m;
      if (m.ParseFromArray(data, n)) CheckEchoed(m.name());
      return;
    }
    case MessageKind::kPlanPathResponse: {
      v1::PlanPathResponse m;
      if (m.ParseFromArray(data, n)) PlanPathResponse(m);
      return;
    }
    case MessageKind::kExportPath: {
      v1::ExportPathRequest m;
      if (m.ParseFromArray(data, n)) ExportPath(m);
      return;
    }
  }
}

}  // namespace
}  // namespace oaipp::fuzz

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  // Strings that are not UTF-8 make protobuf log an error per input; the
  // parse failing is all that matters here.
  google::protobuf::SetLogHandler(nullptr);
  // The documented example, once.
  OAIPP_FUZZ_CHECK(oaipp::api::EchoInput("a\nb") == "\"a\\x0ab\"", "EchoInput example");
  (void)oaipp::fuzz::Fixed();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const auto kind = static_cast<oaipp::fuzz::MessageKind>(data[0] % oaipp::fuzz::kNumKinds);
  oaipp::fuzz::Run(kind, data + 1, size - 1);
  return 0;
}
