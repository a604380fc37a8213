// proto <-> core conversion (api/): a round trip for every
// message and every enum value, defaults against the numbers written in
// mission_service.proto's comments, a table of bad input naming the field,
// a real planned path whose returned coefficients reproduce its samples.
#include "api/geometry.h"
#include "api/map.h"
#include "api/measurement.h"
#include "api/plan.h"
#include "api/spec.h"
#include "api/status.h"

#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/time.h"
#include "core/mapping/field_grid.h"
#include "core/mapping/gp_map.h"
#include "core/planning/oaipp_planner.h"
#include "gmock/gmock.h"
#include "google/protobuf/util/message_differencer.h"
#include "gtest/gtest.h"
#include "tests/api/custom_spec.h"

namespace oaipp::api {
namespace {

using ::google::protobuf::util::MessageDifferencer;
using ::testing::HasSubstr;
using ::testing::StartsWith;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

v1::Vector3 V(double x, double y, double z) {
  v1::Vector3 v;
  v.set_x(x);
  v.set_y(y);
  v.set_z(z);
  return v;
}

void ExpectVecEq(const Vec3& a, const Vec3& b, const std::string& what) {
  EXPECT_EQ(a.x(), b.x()) << what;
  EXPECT_EQ(a.y(), b.y()) << what;
  EXPECT_EQ(a.z(), b.z()) << what;
}

void ExpectStatesEqual(const UavState& a, const UavState& b) {
  ExpectVecEq(a.position_W, b.position_W, "position_W");
  ExpectVecEq(a.velocity_W_m_s, b.velocity_W_m_s, "velocity_W_m_s");
  ExpectVecEq(a.accel_W_m_s2, b.accel_W_m_s2, "accel_W_m_s2");
  EXPECT_EQ(a.mission_time_s, b.mission_time_s);
}

// Yaw passes through degrees, so it may differ by round-off only.
void ExpectObstaclesEqual(const Obstacle& a, const Obstacle& b) {
  EXPECT_EQ(a.id, b.id);
  ASSERT_EQ(a.shape.index(), b.shape.index()) << a.id;
  if (const Box* x = std::get_if<Box>(&a.shape)) {
    const Box& y = std::get<Box>(b.shape);
    ExpectVecEq(x->centre_W, y.centre_W, a.id + " centre");
    ExpectVecEq(x->size_m, y.size_m, a.id + " size");
    EXPECT_DOUBLE_EQ(x->yaw_rad, y.yaw_rad) << a.id;
  } else if (const Prism* p = std::get_if<Prism>(&a.shape)) {
    const Prism& q = std::get<Prism>(b.shape);
    EXPECT_EQ(p->footprint(), q.footprint()) << a.id;
    EXPECT_EQ(p->base_m(), q.base_m()) << a.id;
    EXPECT_EQ(p->top_m(), q.top_m()) << a.id;
  } else {
    const Cylinder& x2 = std::get<Cylinder>(a.shape);
    const Cylinder& y = std::get<Cylinder>(b.shape);
    ExpectVecEq(x2.centre_W, y.centre_W, a.id + " centre");
    EXPECT_EQ(x2.radius_m, y.radius_m) << a.id;
    EXPECT_EQ(x2.height_m, y.height_m) << a.id;
  }
}

void ExpectCommonEqual(const PlannerCommon& a, const PlannerCommon& b, const std::string& what) {
  EXPECT_EQ(a.limits.dynamics.max_speed_m_s, b.limits.dynamics.max_speed_m_s) << what;
  EXPECT_EQ(a.limits.dynamics.max_accel_m_s2, b.limits.dynamics.max_accel_m_s2) << what;
  EXPECT_EQ(a.limits.uav_radius_m, b.limits.uav_radius_m) << what;
  EXPECT_EQ(a.limits.tracking_error_m, b.limits.tracking_error_m) << what;
  EXPECT_EQ(a.limits.obstacle_rule == PlannerLimits::ObstacleRule::kBody,
            b.limits.obstacle_rule == PlannerLimits::ObstacleRule::kBody)
      << what;
  EXPECT_EQ(a.limits.collision_sample_rate_hz, b.limits.collision_sample_rate_hz) << what;
  EXPECT_EQ(a.limits.exact_check_spacing_m, b.limits.exact_check_spacing_m) << what;
  EXPECT_EQ(a.information.kind, b.information.kind) << what;
  EXPECT_EQ(a.information.kappa, b.information.kappa) << what;
  EXPECT_EQ(a.information.h_opt_m, b.information.h_opt_m) << what;
  EXPECT_EQ(a.information.sigma1_m, b.information.sigma1_m) << what;
  EXPECT_EQ(a.information.h_sat_m, b.information.h_sat_m) << what;
  EXPECT_EQ(a.information.confirmation_weight, b.information.confirmation_weight) << what;
  EXPECT_EQ(a.information.decision_threshold, b.information.decision_threshold) << what;
  EXPECT_EQ(a.information.confirmation_phase_s, b.information.confirmation_phase_s) << what;
  EXPECT_EQ(a.information.confirmation_phase_weight, b.information.confirmation_phase_weight)
      << what;
  EXPECT_EQ(a.information.ambiguity_margin, b.information.ambiguity_margin) << what;
  EXPECT_EQ(a.information.second_look_weight, b.information.second_look_weight) << what;
  EXPECT_EQ(a.information.second_look_sharpness, b.information.second_look_sharpness) << what;
  EXPECT_EQ(a.information.confirmation_preposterior, b.information.confirmation_preposterior)
      << what;
  EXPECT_EQ(a.information.detection_discount, b.information.detection_discount) << what;
  EXPECT_EQ(a.weights.k1, b.weights.k1) << what;
  EXPECT_EQ(a.weights.k2, b.weights.k2) << what;
  EXPECT_EQ(a.weights.min_flight_time_s, b.weights.min_flight_time_s) << what;
  EXPECT_EQ(a.seed, b.seed) << what;
}

// MissionConfig has no operator==: every field, one by one.
void ExpectConfigsEqual(const MissionConfig& a, const MissionConfig& b) {
  EXPECT_EQ(a.preset, b.preset);
  EXPECT_EQ(a.field_min_W, b.field_min_W);
  EXPECT_EQ(a.field_max_W, b.field_max_W);
  EXPECT_EQ(a.resolution_m, b.resolution_m);
  EXPECT_EQ(a.gp.length_scale_m, b.gp.length_scale_m);
  EXPECT_EQ(a.gp.signal_var, b.gp.signal_var);
  EXPECT_EQ(a.gp.noise_var, b.gp.noise_var);
  EXPECT_EQ(a.gp.prior_mean, b.gp.prior_mean);
  ASSERT_EQ(a.prior_map == nullptr, b.prior_map == nullptr);
  if (a.prior_map != nullptr) {
    EXPECT_EQ(*a.prior_map, *b.prior_map);
  }
  EXPECT_EQ(a.prior_map_units, b.prior_map_units);
  ASSERT_EQ(a.search_area == nullptr, b.search_area == nullptr);
  if (a.search_area != nullptr) {
    ASSERT_EQ(a.search_area->polygons.size(), b.search_area->polygons.size());
    for (std::size_t i = 0; i < a.search_area->polygons.size(); ++i) {
      EXPECT_EQ(a.search_area->polygons[i].outer_m, b.search_area->polygons[i].outer_m);
      EXPECT_EQ(a.search_area->polygons[i].holes_m, b.search_area->polygons[i].holes_m);
    }
    EXPECT_EQ(a.search_area->mask, b.search_area->mask);
  }
  EXPECT_EQ(a.camera.fov_x_deg, b.camera.fov_x_deg);
  EXPECT_EQ(a.camera.fov_y_deg, b.camera.fov_y_deg);
  EXPECT_EQ(a.camera.rate_hz, b.camera.rate_hz);
  EXPECT_EQ(a.noise.a_var, b.noise.a_var);
  EXPECT_EQ(a.noise.b_per_m, b.noise.b_per_m);
  ASSERT_EQ(a.noise.detector.has_value(), b.noise.detector.has_value());
  if (a.noise.detector.has_value()) {
    EXPECT_EQ(a.noise.detector->p_max, b.noise.detector->p_max);
    EXPECT_EQ(a.noise.detector->h_best_m, b.noise.detector->h_best_m);
    EXPECT_EQ(a.noise.detector->width_m, b.noise.detector->width_m);
    EXPECT_EQ(a.noise.detector->false_positive_rate, b.noise.detector->false_positive_rate);
  }
  EXPECT_EQ(a.min_altitude_m, b.min_altitude_m);
  EXPECT_EQ(a.max_altitude_m, b.max_altitude_m);
  EXPECT_EQ(a.esdf.voxel_size_m, b.esdf.voxel_size_m);
  EXPECT_EQ(a.esdf.truncation_m, b.esdf.truncation_m);
  EXPECT_EQ(a.esdf.max_voxels, b.esdf.max_voxels);

  const PlannerConfig& p = a.planner;
  const PlannerConfig& q = b.planner;
  EXPECT_EQ(p.kind, q.kind);
  ExpectCommonEqual(p.common, q.common, "planner.common");
  EXPECT_EQ(p.oaipp.num_waypoints, q.oaipp.num_waypoints);
  EXPECT_EQ(p.oaipp.greedy_altitudes_m, q.oaipp.greedy_altitudes_m);
  EXPECT_EQ(p.oaipp.greedy_candidates_per_layer, q.oaipp.greedy_candidates_per_layer);
  EXPECT_EQ(p.oaipp.population, q.oaipp.population);
  EXPECT_EQ(p.oaipp.generations, q.oaipp.generations);
  EXPECT_EQ(p.oaipp.stall_generations, q.oaipp.stall_generations);
  EXPECT_EQ(p.oaipp.stall_tolerance, q.oaipp.stall_tolerance);
  EXPECT_EQ(p.oaipp.step_m, q.oaipp.step_m);
  EXPECT_EQ(p.oaipp.refine, q.oaipp.refine);
  EXPECT_EQ(p.oaipp.exact_check_candidates, q.oaipp.exact_check_candidates);
  EXPECT_EQ(p.lawnmower.altitude_m, q.lawnmower.altitude_m);
  EXPECT_EQ(p.lawnmower.start_corner, q.lawnmower.start_corner);
  EXPECT_EQ(p.lawnmower.points_per_plan, q.lawnmower.points_per_plan);
  EXPECT_EQ(p.lawnmower.detour_margin_m, q.lawnmower.detour_margin_m);
  EXPECT_EQ(p.random.max_attempts, q.random.max_attempts);

  ASSERT_EQ(a.obstacles.size(), b.obstacles.size());
  for (std::size_t i = 0; i < a.obstacles.size(); ++i) {
    ExpectObstaclesEqual(a.obstacles[i], b.obstacles[i]);
  }
  ExpectStatesEqual(a.start, b.start);
  EXPECT_EQ(a.budget_s, b.budget_s);
}

// spec -> config -> spec -> config: the two configs agree field for field.
void ExpectRoundTrip(const v1::MissionSpec& spec) {
  absl::StatusOr<MissionConfig> config = MissionSpecToConfig(spec);
  ASSERT_TRUE(config.ok()) << config.status();
  const v1::MissionSpec effective = ConfigToMissionSpec(*config);
  absl::StatusOr<MissionConfig> again = MissionSpecToConfig(effective);
  ASSERT_TRUE(again.ok()) << again.status();
  ExpectConfigsEqual(*config, *again);
  // The effective spec is a fixed point.
  EXPECT_TRUE(MessageDifferencer::ApproximatelyEquals(effective, ConfigToMissionSpec(*again)));
}

using examples::CustomSpec;

// ---------------------------------------------------------------------------
// Missions.

TEST(MissionSpecTest, DefaultSpecTakesTheProtoDocumentedDefaults) {
  absl::StatusOr<MissionConfig> c = MissionSpecToConfig(v1::MissionSpec());
  ASSERT_TRUE(c.ok()) << c.status();
  // Numbers from the comments in mission_service.proto.
  EXPECT_EQ(c->preset, "");
  EXPECT_EQ(c->field_min_W, Vec2(-15, -15));
  EXPECT_EQ(c->field_max_W, Vec2(15, 15));
  EXPECT_EQ(c->resolution_m, 0.75);
  EXPECT_NEAR(c->gp.length_scale_m, 2.752, 5e-4);  // "e^1.3 cells (2.752 m at 0.75 m)"
  EXPECT_DOUBLE_EQ(c->gp.length_scale_m, std::exp(1.3) * 0.75);
  EXPECT_DOUBLE_EQ(c->gp.signal_var, std::exp(0.6));
  EXPECT_DOUBLE_EQ(c->gp.noise_var, std::exp(0.7));
  EXPECT_EQ(c->gp.prior_mean, 0.1);
  EXPECT_EQ(c->camera.fov_x_deg, 45);
  EXPECT_EQ(c->camera.fov_y_deg, 60);
  EXPECT_EQ(c->noise.a_var, 1);
  EXPECT_EQ(c->noise.b_per_m, 0.05);
  EXPECT_FALSE(c->noise.detector.has_value());  // the paper's noise model
  EXPECT_EQ(c->sensor_rate_hz(), 0.15);
  EXPECT_EQ(c->min_altitude_m, 2);
  EXPECT_EQ(c->max_altitude_m, 26);
  EXPECT_EQ(c->planner.common.limits.dynamics.max_speed_m_s, 5);
  EXPECT_EQ(c->planner.common.limits.dynamics.max_accel_m_s2, 3);
  EXPECT_EQ(c->planner.common.limits.uav_radius_m, 1);
  EXPECT_EQ(c->esdf.voxel_size_m, 0.2);
  EXPECT_EQ(c->esdf.truncation_m, 2);
  EXPECT_EQ(c->planner.kind, PlannerKind::kOaIpp);
  EXPECT_EQ(c->planner.common.information.kind, ObjectiveKind::kAdaptive);
  EXPECT_EQ(c->planner.common.seed, 1u);
  EXPECT_EQ(c->planner.oaipp.num_waypoints, 3);
  EXPECT_EQ(c->planner.oaipp.population, 12);
  EXPECT_EQ(c->planner.oaipp.generations, 45);
  EXPECT_EQ(c->planner.common.information.kappa, 1);
  EXPECT_EQ(c->planner.common.information.h_opt_m, 10);
  EXPECT_EQ(c->planner.common.information.sigma1_m, 7);
  EXPECT_EQ(c->planner.common.information.h_sat_m, 26);
  EXPECT_EQ(c->planner.common.information.confirmation_weight, 0);  // the paper's objective
  EXPECT_EQ(c->planner.common.information.decision_threshold, 0.5);
  EXPECT_EQ(c->planner.lawnmower.altitude_m, 10);
  EXPECT_EQ(c->planner.lawnmower.start_corner, -1);
  EXPECT_TRUE(c->obstacles.empty());
  // "default (field centre x, y, 10 m) at rest, time 0"
  ExpectVecEq(c->start.position_W, Vec3(0, 0, 10), "start");
  ExpectVecEq(c->start.velocity_W_m_s, Vec3::Zero(), "start velocity");
  ExpectVecEq(c->start.accel_W_m_s2, Vec3::Zero(), "start acceleration");
  EXPECT_EQ(c->start.mission_time_s, 0);
  EXPECT_EQ(c->budget_s, 150);
}

TEST(MissionSpecTest, DefaultSpecRoundTrips) { ExpectRoundTrip(v1::MissionSpec()); }

// The preposterior form of the confirmation term is off unless asked for,
// and kept through the answered spec when it is.
TEST(MissionSpecTest, ConfirmationPreposteriorRoundTrips) {
  v1::MissionSpec spec;
  spec.mutable_planner()->set_confirmation_weight(100);
  absl::StatusOr<MissionConfig> c = MissionSpecToConfig(spec);
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_FALSE(c->planner.common.information.confirmation_preposterior);
  spec.mutable_planner()->set_confirmation_preposterior(true);
  c = MissionSpecToConfig(spec);
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_TRUE(c->planner.common.information.confirmation_preposterior);
  EXPECT_TRUE(ConfigToMissionSpec(*c).planner().confirmation_preposterior());
  ExpectRoundTrip(spec);
}

// The paper's preset is the defaults but for how far a path keeps from
// obstacles: the paper's r / 2 (1 m radius: 0.5 m) against the UAV's body
// and tracking error (1 + 0.5 m).
TEST(MissionSpecTest, PaperPresetEqualsTheDefaultsButTheClearanceAndRoundTrips) {
  v1::MissionSpec paper;
  paper.set_preset("paper");
  ExpectRoundTrip(paper);
  absl::StatusOr<MissionConfig> a = MissionSpecToConfig(paper);
  absl::StatusOr<MissionConfig> b = MissionSpecToConfig(v1::MissionSpec());
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->preset, "paper");
  EXPECT_EQ(a->planner.common.limits.ObstacleClearance(), 0.5);
  EXPECT_EQ(b->planner.common.limits.ObstacleClearance(), 1.5);
  EXPECT_EQ(b->planner.common.limits.obstacle_rule, PlannerLimits::ObstacleRule::kBody);
  a->preset = "";
  a->planner.common.limits.obstacle_rule = PlannerLimits::ObstacleRule::kBody;
  ExpectConfigsEqual(*a, *b);
}

TEST(MissionSpecTest, FullyCustomSpecConvertsEveryFieldAndRoundTrips) {
  const v1::MissionSpec spec = CustomSpec();
  absl::StatusOr<MissionConfig> c = MissionSpecToConfig(spec);
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_EQ(c->field_min_W, Vec2(-10, -5));
  EXPECT_EQ(c->field_max_W, Vec2(12, 7));
  EXPECT_EQ(c->resolution_m, 0.5);
  EXPECT_EQ(c->gp.length_scale_m, 1.9);
  EXPECT_EQ(c->gp.signal_var, 1.5);
  EXPECT_EQ(c->gp.noise_var, 2.5);
  EXPECT_EQ(c->gp.prior_mean, 0.05);
  EXPECT_EQ(c->camera.fov_x_deg, 50);
  EXPECT_EQ(c->camera.fov_y_deg, 70);
  EXPECT_EQ(c->noise.a_var, 0.8);
  EXPECT_EQ(c->noise.b_per_m, 0.07);
  EXPECT_EQ(c->sensor_rate_hz(), 0.5);
  EXPECT_EQ(c->min_altitude_m, 3);
  EXPECT_EQ(c->max_altitude_m, 30);
  EXPECT_EQ(c->planner.common.limits.dynamics.max_speed_m_s, 7);
  EXPECT_EQ(c->planner.common.limits.dynamics.max_accel_m_s2, 4);
  EXPECT_EQ(c->planner.common.limits.uav_radius_m, 0.8);
  EXPECT_EQ(c->planner.common.limits.tracking_error_m, 0.3);
  EXPECT_EQ(c->esdf.voxel_size_m, 0.25);
  EXPECT_EQ(c->esdf.truncation_m, 3);
  EXPECT_EQ(c->planner.kind, PlannerKind::kOaIppNonAdaptive);
  EXPECT_EQ(c->planner.common.information.kind, ObjectiveKind::kNonAdaptive);
  EXPECT_EQ(c->planner.common.seed, 42u);
  EXPECT_EQ(c->planner.oaipp.num_waypoints, 5);
  EXPECT_EQ(c->planner.oaipp.population, 20);
  EXPECT_EQ(c->planner.oaipp.generations, 10);
  EXPECT_EQ(c->planner.oaipp.stall_generations, 6);
  EXPECT_EQ(c->planner.oaipp.stall_tolerance, 0.002);
  EXPECT_EQ(c->planner.common.information.kappa, 2);
  EXPECT_EQ(c->planner.common.information.h_opt_m, 12);
  EXPECT_EQ(c->planner.common.information.sigma1_m, 5);
  EXPECT_EQ(c->planner.common.information.h_sat_m, 28);
  EXPECT_EQ(c->planner.common.information.decision_threshold, 0.4);
  EXPECT_EQ(c->planner.lawnmower.altitude_m, 14);
  ASSERT_EQ(c->obstacles.size(), 2u);
  EXPECT_EQ(c->obstacles[0].id, "tower");
  EXPECT_DOUBLE_EQ(std::get<Box>(c->obstacles[0].shape).yaw_rad, 0.52359877559829882);  // pi/6
  EXPECT_EQ(std::get<Cylinder>(c->obstacles[1].shape).radius_m, 0.5);
  ExpectVecEq(c->start.position_W, Vec3(8, 4, 9), "start");
  ExpectVecEq(c->start.velocity_W_m_s, Vec3(1, -2, 0.5), "start velocity");
  EXPECT_EQ(c->start.mission_time_s, 12.5);
  EXPECT_EQ(c->budget_s, 200);

  ExpectRoundTrip(spec);
  // Every field was set, so the effective spec is the spec itself.
  EXPECT_TRUE(MessageDifferencer::ApproximatelyEquals(ConfigToMissionSpec(*c), spec));
}

TEST(MissionSpecTest, DetectorNoiseTakesItsDocumentedDefaultsAndRoundTrips) {
  v1::MissionSpec spec;
  spec.mutable_sensor()->mutable_detector_noise();
  absl::StatusOr<MissionConfig> c = MissionSpecToConfig(spec);
  ASSERT_TRUE(c.ok()) << c.status();
  ASSERT_TRUE(c->noise.detector.has_value());
  // Numbers from the comments in mission_service.proto.
  EXPECT_EQ(c->noise.detector->p_max, 0.95);
  EXPECT_EQ(c->noise.detector->h_best_m, 10);
  EXPECT_EQ(c->noise.detector->width_m, 7);
  // var(10 m) = (1 - 0.95) / 0.95, not the paper's 1 - e^-0.5 = 0.3935.
  EXPECT_NEAR(c->noise.Variance(10.0), 0.05 / 0.95, 1e-15);
  ExpectRoundTrip(spec);
  const v1::SensorSpec effective = ConfigToMissionSpec(*c).sensor();
  EXPECT_TRUE(effective.has_detector_noise());
  EXPECT_FALSE(effective.has_noise_a_var());
  EXPECT_FALSE(effective.has_noise_b_per_m());

  v1::DetectorNoise& d = *spec.mutable_sensor()->mutable_detector_noise();
  d.set_p_max(0.8);
  d.set_h_best_m(6);
  d.set_width_m(3);
  c = MissionSpecToConfig(spec);
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_EQ(c->noise.detector->p_max, 0.8);
  EXPECT_EQ(c->noise.detector->h_best_m, 6);
  EXPECT_EQ(c->noise.detector->width_m, 3);
  ExpectRoundTrip(spec);
  EXPECT_TRUE(MessageDifferencer::ApproximatelyEquals(
      ConfigToMissionSpec(*c).sensor().detector_noise(), d));
  EXPECT_FALSE(c->noise.detector->false_positive_rate.has_value());
  EXPECT_FALSE(ConfigToMissionSpec(*c).sensor().detector_noise().has_false_positive_rate());

  d.set_false_positive_rate(0.02);
  c = MissionSpecToConfig(spec);
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_EQ(c->noise.detector->false_positive_rate, 0.02);
  ExpectRoundTrip(spec);
  EXPECT_EQ(ConfigToMissionSpec(*c).sensor().detector_noise().false_positive_rate(), 0.02);
  d.set_false_positive_rate(1.0);
  EXPECT_THAT(
      MissionSpecToConfig(spec).status().message(),
      HasSubstr("spec.sensor.detector_noise.false_positive_rate: must lie in (0, 1), got 1"));
}

TEST(MissionSpecTest, EveryPlannerKindRoundTripsThroughASpec) {
  for (v1::PlannerKind kind :
       {v1::PLANNER_KIND_UNSPECIFIED, v1::PLANNER_KIND_OAIPP, v1::PLANNER_KIND_OAIPP_NONADAPTIVE,
        v1::PLANNER_KIND_LAWNMOWER, v1::PLANNER_KIND_RANDOM}) {
    SCOPED_TRACE(v1::PlannerKind_Name(kind));
    v1::MissionSpec spec;
    spec.mutable_planner()->set_kind(kind);
    ExpectRoundTrip(spec);
    const v1::PlannerKind expected =
        kind == v1::PLANNER_KIND_UNSPECIFIED ? v1::PLANNER_KIND_OAIPP : kind;
    EXPECT_EQ(ConfigToMissionSpec(*MissionSpecToConfig(spec)).planner().kind(), expected);
  }
}

TEST(MissionSpecTest, GpLengthScaleDefaultFollowsTheResolution) {
  v1::MissionSpec spec;
  spec.mutable_field()->set_resolution_m(0.5);  // 30 m / 0.5 m = 60 cells
  absl::StatusOr<MissionConfig> c = MissionSpecToConfig(spec);
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_DOUBLE_EQ(c->gp.length_scale_m, std::exp(1.3) * 0.5);
}

// The default field: 30 m / 0.75 m = 40 x 40 cells.
constexpr int kDefaultCells = 40 * 40;

// A prior map over the default field: `value` everywhere, `peak` at cell 17.
void SetPriorMap(v1::MissionSpec& s, double value, double peak, v1::PriorMapUnits units) {
  v1::PriorMap& m = *s.mutable_gp()->mutable_prior_map();
  m.set_units(units);
  for (int i = 0; i < kDefaultCells; ++i) m.add_values(i == 17 ? peak : value);
}

TEST(MissionSpecTest, PriorMapSetsEveryCellsMeanAndRoundTrips) {
  for (v1::PriorMapUnits units : {v1::PRIOR_MAP_UNITS_LABEL_MEAN, v1::PRIOR_MAP_UNITS_PROBABILITY,
                                  v1::PRIOR_MAP_UNITS_UNSPECIFIED}) {
    v1::MissionSpec spec;
    SetPriorMap(spec, 1.0 / 4096, 0.5, units);
    absl::StatusOr<MissionConfig> c = MissionSpecToConfig(spec);
    ASSERT_TRUE(c.ok()) << c.status();
    ASSERT_NE(c->prior_map, nullptr);
    const Eigen::VectorXd mean = c->PriorMean(kDefaultCells);
    EXPECT_EQ(mean[17], 0.5);
    EXPECT_EQ(mean[18], 1.0 / 4096);
    // gp.prior_mean is the map's average, summed in the cells' order.
    EXPECT_DOUBLE_EQ(c->gp.prior_mean, (0.5 + 1599.0 / 4096) / kDefaultCells);
    EXPECT_EQ(c->prior_map_units, units == v1::PRIOR_MAP_UNITS_PROBABILITY
                                      ? api::PriorMapUnits::kProbability
                                      : api::PriorMapUnits::kLabelMean);
    // The spec says the map, not a scalar mean.
    const v1::MissionSpec effective = ConfigToMissionSpec(*c);
    EXPECT_FALSE(effective.gp().has_prior_mean());
    EXPECT_EQ(effective.gp().prior_map().values_size(), kDefaultCells);
    ExpectRoundTrip(spec);
  }
  // Without a map: the scalar everywhere.
  const MissionConfig plain = *MissionSpecToConfig(v1::MissionSpec());
  EXPECT_EQ(plain.prior_map, nullptr);
  EXPECT_EQ(plain.PriorMean(4), Eigen::VectorXd::Constant(4, 0.1));
}

TEST(MissionSpecTest, DefaultStartIsOverTheFieldCentre) {
  v1::MissionSpec spec;
  spec.mutable_field()->set_x_min_m(0);
  spec.mutable_field()->set_x_max_m(9);
  spec.mutable_field()->set_y_min_m(-3);
  spec.mutable_field()->set_y_max_m(3);
  absl::StatusOr<MissionConfig> c = MissionSpecToConfig(spec);
  ASSERT_TRUE(c.ok()) << c.status();
  ExpectVecEq(c->start.position_W, Vec3(4.5, 0, 10), "start");
}

// ---------------------------------------------------------------------------
// Obstacles, states, vectors, enums.

TEST(ObstacleTest, BoxWithYawRoundTripsInDegreesAtTheApiAndRadiansInTheCore) {
  v1::Obstacle in;
  in.set_id("b");
  *in.mutable_box()->mutable_centre_m() = V(1, 2, 3);
  *in.mutable_box()->mutable_size_m() = V(4, 5, 6);
  in.mutable_box()->set_yaw_deg(90);
  absl::StatusOr<Obstacle> o = ObstacleFromProto(in, "o");
  ASSERT_TRUE(o.ok()) << o.status();
  const Box& box = std::get<Box>(o->shape);
  EXPECT_DOUBLE_EQ(box.yaw_rad, 1.5707963267948966);  // pi / 2
  ExpectVecEq(box.centre_W, Vec3(1, 2, 3), "centre");
  ExpectVecEq(box.size_m, Vec3(4, 5, 6), "size");
  EXPECT_TRUE(MessageDifferencer::ApproximatelyEquals(ObstacleToProto(*o), in));
  absl::StatusOr<Obstacle> again = ObstacleFromProto(ObstacleToProto(*o), "o");
  ASSERT_TRUE(again.ok());
  ExpectObstaclesEqual(*o, *again);
}

TEST(ObstacleTest, CylinderRoundTrips) {
  const Obstacle core{"c", Cylinder{{-1, 2, 5}, 1.5, 10}};
  const v1::Obstacle proto = ObstacleToProto(core);
  EXPECT_EQ(proto.id(), "c");
  ASSERT_TRUE(proto.has_cylinder());
  EXPECT_EQ(proto.cylinder().radius_m(), 1.5);
  EXPECT_EQ(proto.cylinder().height_m(), 10);
  absl::StatusOr<Obstacle> back = ObstacleFromProto(proto, "o");
  ASSERT_TRUE(back.ok()) << back.status();
  ExpectObstaclesEqual(core, *back);
}

TEST(ObstacleTest, PrismRoundTripsCounterClockwise) {
  v1::Obstacle in;
  in.set_id("hall");
  // The L of a building, given clockwise with its closing vertex.
  for (const double v : {0, 20, 8, 20, 8, 8, 20, 8, 20, 0, 0, 0, 0, 20}) {
    in.mutable_prism()->mutable_footprint()->add_xy_m(v);
  }
  in.mutable_prism()->set_base_m(1.5);
  in.mutable_prism()->set_top_m(13.5);
  absl::StatusOr<Obstacle> o = ObstacleFromProto(in, "o");
  ASSERT_TRUE(o.ok()) << o.status();
  const Prism& prism = std::get<Prism>(o->shape);
  ASSERT_EQ(prism.footprint().size(), 6u);
  EXPECT_EQ(prism.footprint().front(), Vec2(0, 0));  // reversed: counter-clockwise
  EXPECT_EQ(prism.footprint()[1], Vec2(20, 0));
  EXPECT_EQ(prism.base_m(), 1.5);
  EXPECT_EQ(prism.top_m(), 13.5);
  const v1::Obstacle out = ObstacleToProto(*o);
  ASSERT_TRUE(out.has_prism());
  EXPECT_EQ(out.prism().footprint().xy_m_size(), 12);
  absl::StatusOr<Obstacle> again = ObstacleFromProto(out, "o");
  ASSERT_TRUE(again.ok()) << again.status();
  ExpectObstaclesEqual(*o, *again);

  // Refusals name the field.
  v1::Obstacle odd = in;
  odd.mutable_prism()->mutable_footprint()->add_xy_m(3);
  EXPECT_THAT(std::string(ObstacleFromProto(odd, "spec.obstacles[2]").status().message()),
              ::testing::StartsWith("spec.obstacles[2].prism.footprint.xy_m: 15 values"));
  v1::Obstacle bow = in;
  bow.mutable_prism()->mutable_footprint()->clear_xy_m();
  for (const double v : {0, 0, 4, 4, 4, 0, 0, 4})
    bow.mutable_prism()->mutable_footprint()->add_xy_m(v);
  EXPECT_THAT(std::string(ObstacleFromProto(bow, "spec.obstacles[2]").status().message()),
              ::testing::StartsWith("spec.obstacles[2].prism.footprint: edges 0 and 2 cross"));
  v1::Obstacle far = in;
  far.mutable_prism()->mutable_footprint()->set_xy_m(3, 1e20);
  EXPECT_THAT(std::string(ObstacleFromProto(far, "spec.obstacles[2]").status().message()),
              ::testing::StartsWith("spec.obstacles[2].prism.footprint.xy_m[2]: vertex 1"));
  v1::Obstacle upside = in;
  upside.mutable_prism()->set_top_m(1.0);
  EXPECT_THAT(std::string(ObstacleFromProto(upside, "spec.obstacles[2]").status().message()),
              ::testing::StartsWith("spec.obstacles[2].prism.top_m: must be finite and above"));
}

TEST(ObstacleTest, ChangeConvertsAddRemoveReplace) {
  v1::UpdateObstaclesRequest request;
  *request.add_add() = ObstacleToProto({"new", Cylinder{{0, 0, 5}, 1, 10}});
  request.add_remove("old");
  *request.add_replace() = ObstacleToProto({"moved", Box{{3, 3, 3}, {1, 1, 6}, 0.0}});
  absl::StatusOr<ObstacleChange> change = ObstacleChangeFromProto(request);
  ASSERT_TRUE(change.ok()) << change.status();
  ASSERT_EQ(change->add.size(), 1u);
  EXPECT_EQ(change->add[0].id, "new");
  EXPECT_EQ(change->remove, std::vector<std::string>{"old"});
  ASSERT_EQ(change->replace.size(), 1u);
  EXPECT_EQ(change->replace[0].id, "moved");
}

TEST(UavStateTest, RoundTripsAndMissingVectorsAreZero) {
  UavState s;
  s.position_W = Vec3(1, -2, 3);
  s.velocity_W_m_s = Vec3(0.5, 0.25, -1);
  s.accel_W_m_s2 = Vec3(-0.1, 0.2, 0.3);
  s.mission_time_s = 42.5;
  absl::StatusOr<UavState> back = UavStateFromProto(UavStateToProto(s), "state");
  ASSERT_TRUE(back.ok()) << back.status();
  ExpectStatesEqual(s, *back);

  v1::UavState sparse;
  *sparse.mutable_position_m() = V(1, 2, 3);
  absl::StatusOr<UavState> z = UavStateFromProto(sparse, "state");
  ASSERT_TRUE(z.ok());
  ExpectVecEq(z->velocity_W_m_s, Vec3::Zero(), "velocity");
  ExpectVecEq(z->accel_W_m_s2, Vec3::Zero(), "acceleration");
  EXPECT_EQ(z->mission_time_s, 0);
}

TEST(Vector3Test, RoundTripsExactly) {
  const Vec3 v(1.0 / 3.0, -1e300, 5e-324);
  ExpectVecEq(FromProto(ToProto(v)), v, "vector");
  const v1::Vector3 p = V(7, 8, 9);
  EXPECT_TRUE(MessageDifferencer::Equals(ToProto(FromProto(p)), p));
}

TEST(PlannerKindTest, EveryCoreKindRoundTrips) {
  for (PlannerKind kind : {PlannerKind::kOaIpp, PlannerKind::kOaIppNonAdaptive,
                           PlannerKind::kLawnmower, PlannerKind::kRandom}) {
    absl::StatusOr<PlannerKind> back = PlannerKindFromProto(PlannerKindToProto(kind));
    ASSERT_TRUE(back.ok());
    EXPECT_EQ(*back, kind) << PlannerKindName(kind);
  }
}

TEST(PlannerKindTest, EveryProtoValueConverts) {
  // Walks the descriptor, so a value added to the proto without a core
  // counterpart fails here.
  const google::protobuf::EnumDescriptor* d = v1::PlannerKind_descriptor();
  for (int i = 0; i < d->value_count(); ++i) {
    const auto kind = static_cast<v1::PlannerKind>(d->value(i)->number());
    SCOPED_TRACE(d->value(i)->name());
    absl::StatusOr<PlannerKind> core = PlannerKindFromProto(kind);
    ASSERT_TRUE(core.ok()) << core.status();
    if (kind == v1::PLANNER_KIND_UNSPECIFIED) {
      EXPECT_EQ(*core, PlannerKind::kOaIpp);
    } else {
      EXPECT_EQ(PlannerKindToProto(*core), kind);
    }
  }
  EXPECT_EQ(*PlannerKindFromProto(v1::PLANNER_KIND_LAWNMOWER), PlannerKind::kLawnmower);
  EXPECT_EQ(*PlannerKindFromProto(v1::PLANNER_KIND_RANDOM), PlannerKind::kRandom);
}

TEST(PlannerKindTest, OutOfRangeNumberIsInvalidArgument) {
  absl::StatusOr<PlannerKind> k = PlannerKindFromProto(static_cast<v1::PlannerKind>(99));
  EXPECT_EQ(k.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(k.status().message()), StartsWith("planner.kind"));
}

// ---------------------------------------------------------------------------
// Measurements.

v1::AddMeasurementRequest ShotWindow() {
  v1::AddMeasurementRequest r;
  r.set_name("missions/m");
  r.set_mission_time_s(6.5);
  *r.mutable_camera_position_m() = V(1, 2, 10);
  r.set_camera_yaw_deg(90);
  return r;
}

TEST(MeasurementTest, FromLabels) {
  v1::AddMeasurementRequest r = ShotWindow();
  for (int c : {7, 3, 11}) r.mutable_labels()->add_cells(c);
  for (double l : {1.0, 0.0, 0.5}) r.mutable_labels()->add_labels(l);
  absl::StatusOr<MeasurementInput> m = MeasurementFromProto(r);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_EQ(m->mission_time_s, 6.5);
  ExpectVecEq(m->pose.p_WC, Vec3(1, 2, 10), "p_WC");
  EXPECT_DOUBLE_EQ(m->pose.yaw_rad, 1.5707963267948966);
  ASSERT_TRUE(m->labels.has_value());
  EXPECT_FALSE(m->detections.has_value());
  EXPECT_EQ(m->labels->cells, (std::vector<int>{7, 3, 11}));
  EXPECT_EQ(m->labels->labels, (std::vector<double>{1.0, 0.0, 0.5}));
}

TEST(MeasurementTest, FromDetectionsWithIntrinsics) {
  v1::AddMeasurementRequest r = ShotWindow();
  v1::ImageDetections& d = *r.mutable_detections();
  v1::CameraIntrinsics& k = *d.mutable_intrinsics();
  k.set_fx_px(500);
  k.set_fy_px(510);
  k.set_cx_px(320);
  k.set_cy_px(240);
  k.set_width_px(640);
  k.set_height_px(480);
  k.set_k1(-0.1);
  k.set_k2(0.01);
  k.set_p1(0.001);
  k.set_p2(-0.002);
  k.set_k3(0.0005);
  v1::PixelBox& b = *d.add_boxes();
  b.set_x_min_px(10);
  b.set_y_min_px(20);
  b.set_x_max_px(640);
  b.set_y_max_px(480);
  b.set_confidence(0.8);
  d.set_min_confidence(0.3);
  absl::StatusOr<MeasurementInput> m = MeasurementFromProto(r);
  ASSERT_TRUE(m.ok()) << m.status();
  ASSERT_TRUE(m->detections.has_value());
  EXPECT_FALSE(m->labels.has_value());
  ASSERT_TRUE(m->detections->intrinsics.has_value());
  const CameraIntrinsics& ci = *m->detections->intrinsics;
  EXPECT_EQ(ci.fx_px, 500);
  EXPECT_EQ(ci.fy_px, 510);
  EXPECT_EQ(ci.cx_px, 320);
  EXPECT_EQ(ci.cy_px, 240);
  EXPECT_EQ(ci.width_px, 640);
  EXPECT_EQ(ci.height_px, 480);
  EXPECT_EQ(ci.k1, -0.1);
  EXPECT_EQ(ci.k2, 0.01);
  EXPECT_EQ(ci.p1, 0.001);
  EXPECT_EQ(ci.p2, -0.002);
  EXPECT_EQ(ci.k3, 0.0005);
  ASSERT_EQ(m->detections->boxes.size(), 1u);
  const PixelBox& box = m->detections->boxes[0];
  EXPECT_EQ(box.x_min_px, 10);
  EXPECT_EQ(box.y_min_px, 20);
  EXPECT_EQ(box.x_max_px, 640);
  EXPECT_EQ(box.y_max_px, 480);
  EXPECT_EQ(box.confidence, 0.8);
  EXPECT_EQ(m->detections->min_confidence, 0.3);
}

TEST(MeasurementTest, FromDetectionsWithoutIntrinsics) {
  v1::AddMeasurementRequest r = ShotWindow();
  v1::PixelBox& b = *r.mutable_detections()->add_boxes();
  b.set_x_min_px(1000);  // beyond any default image: the mission checks that
  b.set_y_min_px(0);
  b.set_x_max_px(1010);
  b.set_y_max_px(5);
  b.set_confidence(1);
  absl::StatusOr<MeasurementInput> m = MeasurementFromProto(r);
  ASSERT_TRUE(m.ok()) << m.status();
  ASSERT_TRUE(m->detections.has_value());
  EXPECT_FALSE(m->detections->intrinsics.has_value());
  ASSERT_EQ(m->detections->boxes.size(), 1u);
  EXPECT_EQ(m->detections->boxes[0].x_max_px, 1010);
  EXPECT_EQ(m->detections->min_confidence, 0);
}

TEST(MeasurementTest, EmptyDetectionsAreAllowed) {
  v1::AddMeasurementRequest r = ShotWindow();
  r.mutable_detections();  // a detector that saw nothing
  absl::StatusOr<MeasurementInput> m = MeasurementFromProto(r);
  ASSERT_TRUE(m.ok()) << m.status();
  ASSERT_TRUE(m->detections.has_value());
  EXPECT_TRUE(m->detections->boxes.empty());
}

// ---------------------------------------------------------------------------
// Bad input: the code and the field named at the start of the message.

struct BadCase {
  std::string name;
  std::function<absl::Status()> convert;
  absl::StatusCode code;
  std::string field;  // the message starts with this
};

absl::Status SpecWith(const std::function<void(v1::MissionSpec&)>& edit) {
  v1::MissionSpec spec;
  edit(spec);
  return MissionSpecToConfig(spec).status();
}

absl::Status CustomSpecWith(const std::function<void(v1::MissionSpec&)>& edit) {
  v1::MissionSpec spec = CustomSpec();
  edit(spec);
  return MissionSpecToConfig(spec).status();
}

absl::Status MeasurementWith(const std::function<void(v1::AddMeasurementRequest&)>& edit) {
  v1::AddMeasurementRequest r = ShotWindow();
  v1::CellLabels& labels = *r.mutable_labels();
  for (int c : {4, 5, 6}) labels.add_cells(c);
  for (double l : {0.0, 1.0, 0.0}) labels.add_labels(l);
  edit(r);
  return MeasurementFromProto(r).status();
}

void SetDetections(v1::AddMeasurementRequest& r, bool with_intrinsics) {
  v1::ImageDetections& d = *r.mutable_detections();
  if (with_intrinsics) {
    v1::CameraIntrinsics& k = *d.mutable_intrinsics();
    k.set_fx_px(500);
    k.set_fy_px(500);
    k.set_cx_px(320);
    k.set_cy_px(240);
    k.set_width_px(640);
    k.set_height_px(480);
  }
  for (int i = 0; i < 2; ++i) {
    v1::PixelBox& b = *d.add_boxes();
    b.set_x_min_px(100);
    b.set_y_min_px(100);
    b.set_x_max_px(200);
    b.set_y_max_px(200);
    b.set_confidence(0.9);
  }
}

std::vector<BadCase> BadCases() {
  using absl::StatusCode;
  const StatusCode kInvalid = StatusCode::kInvalidArgument;
  std::vector<BadCase> cases = {
      {"unknown preset", [] { return SpecWith([](auto& s) { s.set_preset("fast"); }); }, kInvalid,
       "spec.preset: "},
      {"zero resolution",
       [] { return SpecWith([](auto& s) { s.mutable_field()->set_resolution_m(0); }); }, kInvalid,
       "spec.field.resolution_m: must be positive and finite, got 0"},
      {"NaN field corner",
       [] { return SpecWith([](auto& s) { s.mutable_field()->set_x_max_m(kNaN); }); }, kInvalid,
       "spec.field.x_max_m: "},
      {"empty field", [] { return SpecWith([](auto& s) { s.mutable_field()->set_y_max_m(-15); }); },
       kInvalid, "spec.field.y_max_m: "},
      {"extent not a whole number of cells",
       [] { return SpecWith([](auto& s) { s.mutable_field()->set_resolution_m(0.7); }); }, kInvalid,
       "spec.field.resolution_m: "},
      {"too many cells",
       [] { return SpecWith([](auto& s) { s.mutable_field()->set_resolution_m(0.01); }); },
       StatusCode::kResourceExhausted, "spec.field"},
      {"negative length scale",
       [] { return SpecWith([](auto& s) { s.mutable_gp()->set_length_scale_m(-1); }); }, kInvalid,
       "spec.gp.length_scale_m: "},
      {"infinite prior mean",
       [] { return SpecWith([](auto& s) { s.mutable_gp()->set_prior_mean(kInf); }); }, kInvalid,
       "spec.gp.prior_mean: "},
      {"prior map of the wrong size",
       [] {
         return SpecWith([](auto& s) { s.mutable_gp()->mutable_prior_map()->add_values(0.1); });
       },
       kInvalid, "spec.gp.prior_map.values: 1 values for a field of 40 x 40 cells"},
      {"negative prior map value",
       [] {
         return SpecWith(
             [](auto& s) { SetPriorMap(s, 0.1, -0.2, v1::PRIOR_MAP_UNITS_LABEL_MEAN); });
       },
       kInvalid, "spec.gp.prior_map.values[17]: must be in [0, "},
      {"NaN in a prior map",
       [] {
         return SpecWith(
             [](auto& s) { SetPriorMap(s, 0.1, kNaN, v1::PRIOR_MAP_UNITS_UNSPECIFIED); });
       },
       kInvalid, "spec.gp.prior_map.values[17]: "},
      {"a probability above 1",
       [] {
         return SpecWith([](auto& s) { SetPriorMap(s, 0, 1.5, v1::PRIOR_MAP_UNITS_PROBABILITY); });
       },
       kInvalid, "spec.gp.prior_map.values[17]: a probability must be in [0, 1]"},
      {"probabilities summing past 1",
       [] {
         return SpecWith(
             [](auto& s) { SetPriorMap(s, 0.001, 0.001, v1::PRIOR_MAP_UNITS_PROBABILITY); });
       },
       kInvalid, "spec.gp.prior_map.values: probabilities sum to 1.6"},
      {"prior map and prior mean",
       [] {
         return SpecWith([](auto& s) {
           SetPriorMap(s, 0.1, 0.1, v1::PRIOR_MAP_UNITS_LABEL_MEAN);
           s.mutable_gp()->set_prior_mean(0.1);
         });
       },
       kInvalid, "spec.gp.prior_mean: not with spec.gp.prior_map"},
      {"unknown prior map units",
       [] {
         return SpecWith(
             [](auto& s) { SetPriorMap(s, 0.1, 0.1, static_cast<v1::PriorMapUnits>(7)); });
       },
       kInvalid, "spec.gp.prior_map.units: unknown value 7"},
      {"zero noise variance",
       [] { return SpecWith([](auto& s) { s.mutable_gp()->set_noise_var(0); }); }, kInvalid,
       "spec.gp.noise_var: "},
      {"field of view 180",
       [] { return SpecWith([](auto& s) { s.mutable_sensor()->set_fov_x_deg(180); }); }, kInvalid,
       "spec.sensor.fov_x_deg: "},
      {"zero sensor rate",
       [] { return SpecWith([](auto& s) { s.mutable_sensor()->set_rate_hz(0); }); }, kInvalid,
       "spec.sensor.rate_hz: "},
      {"negative noise B",
       [] { return SpecWith([](auto& s) { s.mutable_sensor()->set_noise_b_per_m(-0.1); }); },
       kInvalid, "spec.sensor.noise_b_per_m: "},
      {"detector noise with the paper's A",
       [] {
         return SpecWith([](auto& s) {
           s.mutable_sensor()->set_noise_a_var(1.0);
           s.mutable_sensor()->mutable_detector_noise();
         });
       },
       kInvalid, "spec.sensor.detector_noise: replaces noise_a_var and noise_b_per_m"},
      {"detector noise with the paper's B",
       [] {
         return SpecWith([](auto& s) {
           s.mutable_sensor()->set_noise_b_per_m(0.05);
           s.mutable_sensor()->mutable_detector_noise();
         });
       },
       kInvalid, "spec.sensor.detector_noise: replaces noise_a_var and noise_b_per_m"},
      {"detector noise best below ground",
       [] {
         return SpecWith(
             [](auto& s) { s.mutable_sensor()->mutable_detector_noise()->set_h_best_m(-2); });
       },
       kInvalid, "spec.sensor.detector_noise.h_best_m: must be >= 0"},
      {"detector noise p_max 1",
       [] {
         return SpecWith(
             [](auto& s) { s.mutable_sensor()->mutable_detector_noise()->set_p_max(1); });
       },
       kInvalid, "spec.sensor.detector_noise.p_max: must lie in (0, 1), got 1"},
      {"detector noise p_max 0",
       [] {
         return SpecWith(
             [](auto& s) { s.mutable_sensor()->mutable_detector_noise()->set_p_max(0); });
       },
       kInvalid, "spec.sensor.detector_noise.p_max: "},
      {"detector noise NaN best altitude",
       [] {
         return SpecWith(
             [](auto& s) { s.mutable_sensor()->mutable_detector_noise()->set_h_best_m(kNaN); });
       },
       kInvalid, "spec.sensor.detector_noise.h_best_m: "},
      {"detector noise zero width",
       [] {
         return SpecWith(
             [](auto& s) { s.mutable_sensor()->mutable_detector_noise()->set_width_m(0); });
       },
       kInvalid, "spec.sensor.detector_noise.width_m: "},
      {"max altitude below min",
       [] {
         return SpecWith([](auto& s) {
           s.mutable_flight()->set_min_altitude_m(12);
           s.mutable_flight()->set_max_altitude_m(11);
         });
       },
       kInvalid, "spec.flight.max_altitude_m: "},
      {"negative min altitude",
       [] { return SpecWith([](auto& s) { s.mutable_flight()->set_min_altitude_m(-1); }); },
       kInvalid, "spec.flight.min_altitude_m: "},
      {"zero speed",
       [] { return SpecWith([](auto& s) { s.mutable_flight()->set_max_speed_m_s(0); }); }, kInvalid,
       "spec.flight.max_speed_m_s: "},
      {"NaN acceleration",
       [] { return SpecWith([](auto& s) { s.mutable_flight()->set_max_accel_m_s2(kNaN); }); },
       kInvalid, "spec.flight.max_accel_m_s2: "},
      {"zero UAV radius",
       [] { return SpecWith([](auto& s) { s.mutable_flight()->set_uav_radius_m(0); }); }, kInvalid,
       "spec.flight.uav_radius_m: "},
      {"negative tracking error",
       [] { return SpecWith([](auto& s) { s.mutable_flight()->set_tracking_error_m(-0.1); }); },
       kInvalid, "spec.flight.tracking_error_m: "},
      {"ESDF voxel above 10 m",
       [] { return SpecWith([](auto& s) { s.mutable_flight()->set_esdf_voxel_m(11); }); }, kInvalid,
       "spec.flight.esdf_voxel_m: "},
      {"ESDF truncation below the voxel",
       [] { return SpecWith([](auto& s) { s.mutable_flight()->set_esdf_truncation_m(0.1); }); },
       kInvalid, "spec.flight.esdf_truncation_m: "},
      {"unknown planner kind",
       [] {
         return SpecWith(
             [](auto& s) { s.mutable_planner()->set_kind(static_cast<v1::PlannerKind>(42)); });
       },
       kInvalid, "spec.planner.kind: "},
      {"one waypoint",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_num_waypoints(1); }); },
       kInvalid, "spec.planner.num_waypoints: "},
      {"21 waypoints",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_num_waypoints(21); }); },
       kInvalid, "spec.planner.num_waypoints: "},
      {"population 4",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_population(4); }); }, kInvalid,
       "spec.planner.population: "},
      {"negative generations",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_generations(-1); }); }, kInvalid,
       "spec.planner.generations: "},
      {"negative stall generations",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_stall_generations(-1); }); },
       kInvalid, "spec.planner.stall_generations: "},
      {"stall tolerance above 1",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_stall_tolerance(1.5); }); },
       kInvalid, "spec.planner.stall_tolerance: "},
      {"negative kappa",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_kappa(-0.5); }); }, kInvalid,
       "spec.planner.kappa: "},
      {"negative confirmation weight",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_confirmation_weight(-1); }); },
       kInvalid, "spec.planner.confirmation_weight: "},
      {"confirmation with the trace objective",
       [] {
         return SpecWith([](auto& s) {
           s.mutable_planner()->set_kind(v1::PLANNER_KIND_OAIPP_NONADAPTIVE);
           s.mutable_planner()->set_confirmation_weight(2);
         });
       },
       kInvalid, "spec.planner.confirmation_weight: "},
      {"decision threshold 1",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_decision_threshold(1); }); },
       kInvalid, "spec.planner.decision_threshold: "},
      {"negative confirmation phase",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_confirmation_phase_s(-1); }); },
       kInvalid, "spec.planner.confirmation_phase_s: "},
      {"infinite confirmation phase weight",
       [] {
         return SpecWith([](auto& s) {
           s.mutable_planner()->set_confirmation_phase_weight(
               std::numeric_limits<double>::infinity());
         });
       },
       kInvalid, "spec.planner.confirmation_phase_weight: "},
      {"negative second-look weight",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_second_look_weight(-1); }); },
       kInvalid, "spec.planner.second_look_weight: "},
      {"detection discount of 0",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_detection_discount(0); }); },
       kInvalid, "spec.planner.detection_discount: "},
      {"detection discount above 1",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_detection_discount(1.5); }); },
       kInvalid, "spec.planner.detection_discount: "},
      {"infinite second-look sharpness",
       [] {
         return SpecWith([](auto& s) {
           s.mutable_planner()->set_second_look_sharpness(std::numeric_limits<double>::infinity());
         });
       },
       kInvalid, "spec.planner.second_look_sharpness: "},
      {"preposterior confirmation without its weight",
       [] {
         return SpecWith([](auto& s) { s.mutable_planner()->set_confirmation_preposterior(true); });
       },
       kInvalid, "spec.planner.confirmation_preposterior: "},
      {"ambiguity margin above 0.5",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_ambiguity_margin(0.6); }); },
       kInvalid, "spec.planner.ambiguity_margin: "},
      {"confirmation phase with the trace objective",
       [] {
         return SpecWith([](auto& s) {
           s.mutable_planner()->set_kind(v1::PLANNER_KIND_OAIPP_NONADAPTIVE);
           s.mutable_planner()->set_confirmation_phase_s(30);
         });
       },
       kInvalid, "spec.planner.confirmation_phase_s: "},
      {"zero sigma1",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_sigma1_m(0); }); }, kInvalid,
       "spec.planner.sigma1_m: "},
      {"zero lawnmower altitude",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_lawnmower_altitude_m(0); }); },
       kInvalid, "spec.planner.lawnmower_altitude_m: "},
      {"lawnmower start corner 4",
       [] { return SpecWith([](auto& s) { s.mutable_planner()->set_lawnmower_start_corner(4); }); },
       kInvalid, "spec.planner.lawnmower_start_corner: "},
      {"flat box",
       [] {
         return CustomSpecWith(
             [](auto& s) { s.mutable_obstacles(0)->mutable_box()->mutable_size_m()->set_y(0); });
       },
       kInvalid, "spec.obstacles[0].box.size_m.y: "},
      {"obstacle without shape",
       [] { return CustomSpecWith([](auto& s) { s.mutable_obstacles(0)->clear_shape(); }); },
       kInvalid, "spec.obstacles[0].shape: "},
      {"obstacle without id",
       [] { return CustomSpecWith([](auto& s) { s.mutable_obstacles(1)->clear_id(); }); }, kInvalid,
       "spec.obstacles[1].id: "},
      {"obstacle id of 129 characters",
       [] {
         return CustomSpecWith(
             [](auto& s) { s.mutable_obstacles(0)->set_id(std::string(129, 'a')); });
       },
       kInvalid, "spec.obstacles[0].id: "},
      {"duplicate obstacle id",
       [] { return CustomSpecWith([](auto& s) { s.mutable_obstacles(1)->set_id("tower"); }); },
       kInvalid, "spec.obstacles[1].id: "},
      {"NaN cylinder radius",
       [] {
         return CustomSpecWith(
             [](auto& s) { s.mutable_obstacles(1)->mutable_cylinder()->set_radius_m(kNaN); });
       },
       kInvalid, "spec.obstacles[1].cylinder.radius_m: "},
      {"infinite box yaw",
       [] {
         return CustomSpecWith(
             [](auto& s) { s.mutable_obstacles(0)->mutable_box()->set_yaw_deg(kInf); });
       },
       kInvalid, "spec.obstacles[0].box.yaw_deg: "},
      {"NaN start",
       [] {
         return SpecWith([](auto& s) { *s.mutable_start()->mutable_position_m() = V(kNaN, 0, 5); });
       },
       kInvalid, "spec.start.position_m.x: "},
      {"start outside the volume",
       [] {
         return SpecWith([](auto& s) { *s.mutable_start()->mutable_position_m() = V(0, 0, 30); });
       },
       kInvalid, "spec.start.position_m: "},
      {"negative start time",
       [] {
         return SpecWith([](auto& s) {
           *s.mutable_start()->mutable_position_m() = V(0, 0, 5);
           s.mutable_start()->set_mission_time_s(-1);
         });
       },
       kInvalid, "spec.start.mission_time_s: "},
      {"start too fast",
       [] {
         return SpecWith([](auto& s) {
           *s.mutable_start()->mutable_position_m() = V(0, 0, 5);
           *s.mutable_start()->mutable_velocity_m_s() = V(4, 4, 0);  // 5.66 > 5 m/s
         });
       },
       kInvalid, "spec.start.velocity_m_s: "},
      {"default start above the ceiling",
       [] { return SpecWith([](auto& s) { s.mutable_flight()->set_max_altitude_m(8); }); },
       kInvalid, "spec.start: "},
      {"zero budget", [] { return SpecWith([](auto& s) { s.set_budget_s(0); }); }, kInvalid,
       "spec.budget_s: "},
      {"infinite budget", [] { return SpecWith([](auto& s) { s.set_budget_s(kInf); }); }, kInvalid,
       "spec.budget_s: "},

      // Obstacle updates.
      {"flat added box",
       [] {
         v1::UpdateObstaclesRequest r;
         for (int i = 0; i < 3; ++i) {
           *r.add_add() = ObstacleToProto({absl::StrCat("b", i), Box{}});
         }
         r.mutable_add(2)->mutable_box()->mutable_size_m()->set_y(-1);
         return ObstacleChangeFromProto(r).status();
       },
       kInvalid, "add[2].box.size_m.y: "},
      {"empty removed id",
       [] {
         v1::UpdateObstaclesRequest r;
         r.add_remove("");
         return ObstacleChangeFromProto(r).status();
       },
       kInvalid, "remove[0]: "},
      {"id twice in one change",
       [] {
         v1::UpdateObstaclesRequest r;
         *r.add_add() = ObstacleToProto({"x", Box{}});
         *r.add_replace() = ObstacleToProto({"x", Box{}});
         return ObstacleChangeFromProto(r).status();
       },
       kInvalid, "replace[0].id: "},

      // Measurements.
      {"no data", [] { return MeasurementWith([](auto& r) { r.clear_data(); }); }, kInvalid,
       "data: "},
      {"negative time", [] { return MeasurementWith([](auto& r) { r.set_mission_time_s(-1); }); },
       kInvalid, "mission_time_s: "},
      {"camera on the ground",
       [] { return MeasurementWith([](auto& r) { *r.mutable_camera_position_m() = V(0, 0, 0); }); },
       kInvalid, "camera_position_m.z: "},
      {"NaN camera x",
       [] {
         return MeasurementWith([](auto& r) { *r.mutable_camera_position_m() = V(kNaN, 0, 5); });
       },
       kInvalid, "camera_position_m.x: "},
      {"infinite yaw", [] { return MeasurementWith([](auto& r) { r.set_camera_yaw_deg(kInf); }); },
       kInvalid, "camera_yaw_deg: "},
      {"more labels than cells",
       [] { return MeasurementWith([](auto& r) { r.mutable_labels()->add_labels(1); }); }, kInvalid,
       "labels.labels: "},
      {"negative cell",
       [] { return MeasurementWith([](auto& r) { r.mutable_labels()->set_cells(1, -3); }); },
       kInvalid, "labels.cells[1]: "},
      {"repeated cell",
       [] { return MeasurementWith([](auto& r) { r.mutable_labels()->set_cells(2, 4); }); },
       kInvalid, "labels.cells[2]: "},
      {"label above 1",
       [] { return MeasurementWith([](auto& r) { r.mutable_labels()->set_labels(0, 1.5); }); },
       kInvalid, "labels.labels[0]: "},
      {"NaN label",
       [] { return MeasurementWith([](auto& r) { r.mutable_labels()->set_labels(2, kNaN); }); },
       kInvalid, "labels.labels[2]: "},
      {"zero focal length",
       [] {
         return MeasurementWith([](auto& r) {
           SetDetections(r, true);
           r.mutable_detections()->mutable_intrinsics()->set_fx_px(0);
         });
       },
       kInvalid, "detections.intrinsics.fx_px: "},
      {"zero image height",
       [] {
         return MeasurementWith([](auto& r) {
           SetDetections(r, true);
           r.mutable_detections()->mutable_intrinsics()->set_height_px(0);
         });
       },
       kInvalid, "detections.intrinsics.height_px: "},
      {"inverted box",
       [] {
         return MeasurementWith([](auto& r) {
           SetDetections(r, false);
           r.mutable_detections()->mutable_boxes(1)->set_x_max_px(50);
         });
       },
       kInvalid, "detections.boxes[1].x_max_px: "},
      {"box beyond the image width",
       [] {
         return MeasurementWith([](auto& r) {
           SetDetections(r, true);
           r.mutable_detections()->mutable_boxes(0)->set_x_max_px(641);
         });
       },
       kInvalid, "detections.boxes[0].x_max_px: "},
      {"negative box corner",
       [] {
         return MeasurementWith([](auto& r) {
           SetDetections(r, false);
           r.mutable_detections()->mutable_boxes(1)->set_y_min_px(-1);
         });
       },
       kInvalid, "detections.boxes[1].y_min_px: "},
      {"confidence 2",
       [] {
         return MeasurementWith([](auto& r) {
           SetDetections(r, false);
           r.mutable_detections()->mutable_boxes(0)->set_confidence(2);
         });
       },
       kInvalid, "detections.boxes[0].confidence: "},
      {"negative min confidence",
       [] {
         return MeasurementWith([](auto& r) {
           SetDetections(r, false);
           r.mutable_detections()->set_min_confidence(-0.1);
         });
       },
       kInvalid, "detections.min_confidence: "},
  };
  return cases;
}

TEST(BadInputTest, EachIsRefusedWithTheRightCodeAndTheFieldNamedFirst) {
  const std::vector<BadCase> cases = BadCases();
  ASSERT_GE(cases.size(), 15u);
  for (const BadCase& c : cases) {
    SCOPED_TRACE(c.name);
    const absl::Status status = c.convert();
    EXPECT_EQ(status.code(), c.code) << status;
    EXPECT_THAT(std::string(status.message()), StartsWith(c.field));
  }
}

TEST(BadInputTest, ToGrpcStatusKeepsCodeAndMessage) {
  const absl::Status bad = SpecWith([](auto& s) { s.mutable_field()->set_resolution_m(0); });
  const grpc::Status g = ToGrpcStatus(bad);
  EXPECT_EQ(g.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(g.error_message(), std::string(bad.message()));
  EXPECT_TRUE(ToGrpcStatus(absl::OkStatus()).ok());
  const std::pair<absl::Status, grpc::StatusCode> pairs[] = {
      {absl::NotFoundError("x"), grpc::StatusCode::NOT_FOUND},
      {absl::AlreadyExistsError("x"), grpc::StatusCode::ALREADY_EXISTS},
      {absl::FailedPreconditionError("x"), grpc::StatusCode::FAILED_PRECONDITION},
      {absl::ResourceExhaustedError("x"), grpc::StatusCode::RESOURCE_EXHAUSTED},
      {absl::DeadlineExceededError("x"), grpc::StatusCode::DEADLINE_EXCEEDED},
      {absl::InternalError("x"), grpc::StatusCode::INTERNAL},
  };
  for (const auto& [status, code] : pairs) EXPECT_EQ(ToGrpcStatus(status).error_code(), code);
}

// ---------------------------------------------------------------------------
// Plans and maps.

// Field [-7.5, 7.5]^2 at 0.75 m (20 x 20 cells), flight altitudes [2, 26] m,
// one mast off the start:
//
//   y ^
//     |      S         S = start (0, 0, 10)
//     |          O     O = mast at (4, -4), r = 1 m, 12 m tall
//     +--------> x
struct SmallMission {
  std::unique_ptr<Environment> env;
  std::unique_ptr<GpMap> map;
};

SmallMission MakeSmallMission() {
  SmallMission m;
  auto env = Environment::Create({{-7.5, -7.5, 2}, {7.5, 7.5, 26}}, {.voxel_size_m = 0.5});
  EXPECT_TRUE(env.ok()) << env.status();
  EXPECT_TRUE(env->Apply({.add = {{"mast", Cylinder{{4, -4, 6}, 1.0, 12.0}}}}).ok());
  m.env = std::make_unique<Environment>(std::move(env).value());
  auto grid = FieldGrid::FromBounds({-7.5, -7.5}, {7.5, 7.5}, 0.75);
  EXPECT_TRUE(grid.ok()) << grid.status();
  auto map = GpMap::Create(*grid, GpParams::PaperPreset(0.75));
  EXPECT_TRUE(map.ok()) << map.status();
  m.map = std::make_unique<GpMap>(std::move(map).value());
  return m;
}

// p(tau) and p'(tau) of one axis from the returned coefficients (Horner).
std::pair<double, double> Evaluate(const google::protobuf::RepeatedField<double>& c, double tau) {
  double p = 0.0, v = 0.0;
  for (int k = c.size() - 1; k >= 0; --k) {
    v = v * tau + p;
    p = p * tau + c[k];
  }
  return {p, v};
}

TEST(TrajectoryFromProtoTest, BadTrajectoriesAreNamed) {
  v1::Trajectory t;
  EXPECT_THAT(std::string(TrajectoryFromProto(t).status().message()),
              StartsWith("trajectory.segments: "));
  v1::PolynomialSegment& seg = *t.add_segments();
  seg.set_duration_s(0.0);
  EXPECT_THAT(std::string(TrajectoryFromProto(t).status().message()),
              StartsWith("trajectory.segments[0].duration_s: "));
  seg.set_duration_s(1.0);
  for (int k = 0; k < 11; ++k) seg.add_x_coefficients(1.0);
  EXPECT_THAT(std::string(TrajectoryFromProto(t).status().message()),
              StartsWith("trajectory.segments[0].x_coefficients: "));
  seg.clear_x_coefficients();
  seg.add_z_coefficients(std::numeric_limits<double>::quiet_NaN());
  EXPECT_THAT(std::string(TrajectoryFromProto(t).status().message()),
              StartsWith("trajectory.segments[0]: "));
  seg.clear_z_coefficients();
  seg.add_z_coefficients(2.0);  // missing coefficients are zero: z = 2
  absl::StatusOr<PolynomialTrajectory> ok = TrajectoryFromProto(t);
  ASSERT_TRUE(ok.ok()) << ok.status();
  EXPECT_EQ(ok->Position(0.5), Vec3(0, 0, 2));
}

// A measurement written by a client reads back as the same input.
TEST(MeasurementTest, ToProtoAndBackIsTheSameInput) {
  MeasurementInput labels{.mission_time_s = 12.5, .pose = CameraPose{Vec3(1, -2, 9), 0.0}};
  labels.labels = CellLabels{.cells = {4, 9, 2}, .labels = {0.0, 1.0, 0.25}};
  MeasurementInput boxes{.mission_time_s = 3.0, .pose = CameraPose{Vec3(0, 0, 12), DegToRad(30)}};
  boxes.detections = MeasurementInput::Detections{
      .intrinsics = IntrinsicsForFov(480, 640, 45, 60).value(),
      .boxes =
          {{.x_min_px = 10, .y_min_px = 20, .x_max_px = 40, .y_max_px = 90, .confidence = 0.8}},
      .min_confidence = 0.5};
  for (const MeasurementInput& in : {labels, boxes}) {
    v1::AddMeasurementRequest request;
    MeasurementToProto(in, &request);
    absl::StatusOr<MeasurementInput> out = MeasurementFromProto(request);
    ASSERT_TRUE(out.ok()) << out.status();
    EXPECT_EQ(out->mission_time_s, in.mission_time_s);
    EXPECT_EQ(out->pose.p_WC, in.pose.p_WC);
    EXPECT_NEAR(out->pose.yaw_rad, in.pose.yaw_rad, 1e-15);
    ASSERT_EQ(out->labels.has_value(), in.labels.has_value());
    if (in.labels) {
      EXPECT_EQ(out->labels->cells, in.labels->cells);
      EXPECT_EQ(out->labels->labels, in.labels->labels);
    }
    ASSERT_EQ(out->detections.has_value(), in.detections.has_value());
    if (in.detections) {
      EXPECT_EQ(out->detections->intrinsics->fx_px, in.detections->intrinsics->fx_px);
      EXPECT_EQ(out->detections->intrinsics->height_px, in.detections->intrinsics->height_px);
      ASSERT_EQ(out->detections->boxes.size(), 1u);
      EXPECT_EQ(out->detections->boxes[0].x_max_px, 40);
      EXPECT_EQ(out->detections->boxes[0].confidence, 0.8);
      EXPECT_EQ(out->detections->min_confidence, 0.5);
    }
  }
}

TEST(PlannedPathTest, CoefficientsReproduceTheSamplesAndSamplesSpanTheTrajectory) {
  SmallMission mission = MakeSmallMission();
  OaIppConfig config;
  config.population = 6;
  config.generations = 2;
  OaIppPlanner planner(PlannerCommon{.seed = 3}, config);
  UavState start;
  start.position_W = Vec3(0, 0, 10);
  start.mission_time_s = 4.0;
  const PlanningContext view{mission.env.get(), mission.map.get(), DownwardCamera{}, SensorNoise{},
                             /*next_shot_mission_s=*/6.0};
  absl::StatusOr<PlannedPath> path = planner.Plan(view, start, absl::InfiniteFuture());
  ASSERT_TRUE(path.ok()) << path.status();

  v1::PlanPathResponse out;
  out.set_objective(-123);  // stale content is cleared
  PlannedPathToProto(*path, &out);

  const v1::Trajectory& t = out.trajectory();
  const double duration_s = path->trajectory.Duration();
  EXPECT_EQ(t.duration_s(), duration_s);
  ASSERT_EQ(t.segments_size(), path->trajectory.NumSegments());
  double total_s = 0.0;
  std::vector<double> starts_s;
  for (const v1::PolynomialSegment& s : t.segments()) {
    EXPECT_EQ(s.x_coefficients_size(), 10);  // degree 9
    EXPECT_EQ(s.y_coefficients_size(), 10);
    EXPECT_EQ(s.z_coefficients_size(), 10);
    EXPECT_GT(s.duration_s(), 0.0);
    starts_s.push_back(total_s);
    total_s += s.duration_s();
  }
  EXPECT_NEAR(total_s, duration_s, 1e-9);

  // Samples at 10 Hz from 0, then the end itself.
  ASSERT_GE(t.samples_size(), 2);
  EXPECT_EQ(t.samples(0).t_s(), 0.0);
  EXPECT_EQ(t.samples(t.samples_size() - 1).t_s(), duration_s);
  for (int j = 0; j + 1 < t.samples_size(); ++j) {
    EXPECT_NEAR(t.samples(j).t_s(), 0.1 * j, 1e-12);
  }
  const double last_gap = duration_s - t.samples(t.samples_size() - 2).t_s();
  EXPECT_GT(last_gap, 0.0);
  EXPECT_LE(last_gap, 0.1 + 1e-12);
  // Both ends: the UAV's start and the last control waypoint.
  EXPECT_LT((FromProto(t.samples(0).position_m()) - Vec3(0, 0, 10)).norm(), 1e-9);
  EXPECT_LT(
      (FromProto(t.samples(t.samples_size() - 1).position_m()) - path->control_waypoints_W.back())
          .norm(),
      1e-9);

  // Every sample from the coefficients alone: the segment holding t_s,
  // tau = t_s - its start.
  for (const v1::TrajectorySample& s : t.samples()) {
    int i = 0;
    while (i + 1 < t.segments_size() && s.t_s() >= starts_s[i + 1]) ++i;
    const double tau = s.t_s() - starts_s[i];
    const v1::PolynomialSegment& seg = t.segments(i);
    const auto [px, vx] = Evaluate(seg.x_coefficients(), tau);
    const auto [py, vy] = Evaluate(seg.y_coefficients(), tau);
    const auto [pz, vz] = Evaluate(seg.z_coefficients(), tau);
    EXPECT_LT((Vec3(px, py, pz) - FromProto(s.position_m())).norm(), 1e-9) << "t " << s.t_s();
    EXPECT_LT((Vec3(vx, vy, vz) - FromProto(s.velocity_m_s())).norm(), 1e-9) << "t " << s.t_s();
  }

  // Read back into the core's type (what a client flies): the same samples.
  absl::StatusOr<PolynomialTrajectory> back = TrajectoryFromProto(t);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->NumSegments(), t.segments_size());
  for (const v1::TrajectorySample& s : t.samples()) {
    EXPECT_LT((back->Position(s.t_s()) - FromProto(s.position_m())).norm(), 1e-9);
    EXPECT_LT((back->Velocity(s.t_s()) - FromProto(s.velocity_m_s())).norm(), 1e-9);
  }

  ASSERT_EQ(out.control_waypoints_m_size(), static_cast<int>(path->control_waypoints_W.size()));
  for (int i = 0; i < out.control_waypoints_m_size(); ++i) {
    ExpectVecEq(FromProto(out.control_waypoints_m(i)), path->control_waypoints_W[i], "waypoint");
  }
  ASSERT_EQ(out.measurement_poses_size(), static_cast<int>(path->measurement_poses.size()));
  for (int i = 0; i < out.measurement_poses_size(); ++i) {
    const MeasurementPose& p = path->measurement_poses[i];
    EXPECT_EQ(out.measurement_poses(i).t_s(), p.t_s);
    EXPECT_EQ(out.measurement_poses(i).mission_time_s(), p.mission_time_s);
    ExpectVecEq(FromProto(out.measurement_poses(i).position_m()), p.position_W, "pose");
  }
  EXPECT_EQ(out.objective(), path->objective);
  EXPECT_EQ(out.information(), path->information);
  EXPECT_EQ(out.collision_samples(), path->collision_samples);
  EXPECT_TRUE(out.collision_free());
  EXPECT_EQ(out.next_shot_mission_s(), path->next_shot_mission_s);
  EXPECT_EQ(out.stats().evaluations(), path->stats.evaluations);
  EXPECT_EQ(out.stats().generations(), path->stats.generations);
  EXPECT_EQ(out.stats().wall_time_s(), path->stats.wall_time_s);
  EXPECT_EQ(out.stats().stop_reason(), path->stats.stop_reason);
  EXPECT_EQ(out.stats().initial_objective(), path->stats.initial_objective);
}

TEST(MapTest, MapToProtoDescribesTheGridAndCells) {
  SmallMission mission = MakeSmallMission();
  v1::GetMapResponse out;
  MapToProto(*mission.map, /*include_cells=*/false, &out);
  EXPECT_EQ(out.nx(), 20);
  EXPECT_EQ(out.ny(), 20);
  EXPECT_EQ(out.resolution_m(), 0.75);
  EXPECT_EQ(out.x_min_m(), -7.5);
  EXPECT_EQ(out.y_min_m(), -7.5);
  EXPECT_EQ(out.mean_size(), 0);
  EXPECT_DOUBLE_EQ(out.trace(), mission.map->Covariance().trace());
  MapToProto(*mission.map, /*include_cells=*/true, &out);
  ASSERT_EQ(out.mean_size(), 400);
  ASSERT_EQ(out.variance_size(), 400);
  EXPECT_EQ(out.mean(17), 0.1);  // the prior mean
  EXPECT_EQ(out.variance(17), mission.map->Covariance()(17, 17));
}

}  // namespace
}  // namespace oaipp::api
