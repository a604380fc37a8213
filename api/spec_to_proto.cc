// MissionConfig back to the API's MissionSpec (api/spec.h), every field set:
// what GetMission answers and what a snapshot keeps.
#include "api/geodetic.h"
#include "api/geometry.h"
#include "api/internal/airspace_spec.h"
#include "api/internal/home_spec.h"
#include "api/internal/search_area_spec.h"
#include "api/spec.h"

namespace oaipp::api {
namespace {

// A camera and its noise as a SensorSpec with every field set.
void WriteSensor(const DownwardCamera& camera, const SensorNoise& noise, v1::SensorSpec& s) {
  s.set_fov_x_deg(camera.fov_x_deg);
  s.set_fov_y_deg(camera.fov_y_deg);
  if (noise.detector.has_value()) {
    v1::DetectorNoise& d = *s.mutable_detector_noise();
    d.set_p_max(noise.detector->p_max);
    d.set_h_best_m(noise.detector->h_best_m);
    d.set_width_m(noise.detector->width_m);
    if (noise.detector->false_positive_rate.has_value()) {
      d.set_false_positive_rate(*noise.detector->false_positive_rate);
    }
  } else {
    s.set_noise_a_var(noise.a_var);
    s.set_noise_b_per_m(noise.b_per_m);
  }
  s.set_rate_hz(camera.rate_hz);
}

// A UAV's speed, acceleration and radius into `f`.
void WriteLimits(const PlannerLimits& limits, v1::FlightSpec& f) {
  f.set_max_speed_m_s(limits.dynamics.max_speed_m_s);
  f.set_max_accel_m_s2(limits.dynamics.max_accel_m_s2);
  f.set_uav_radius_m(limits.uav_radius_m);
  f.set_tracking_error_m(limits.tracking_error_m);
}

}  // namespace

v1::MissionSpec ConfigToMissionSpec(const MissionConfig& c) {
  v1::MissionSpec spec;
  spec.set_preset(c.preset);

  v1::FieldSpec& f = *spec.mutable_field();
  f.set_x_min_m(c.field_min_W.x());
  f.set_y_min_m(c.field_min_W.y());
  f.set_x_max_m(c.field_max_W.x());
  f.set_y_max_m(c.field_max_W.y());
  f.set_resolution_m(c.resolution_m);
  f.set_map_backend(c.map_backend == MapBackend::kDense    ? v1::MAP_BACKEND_DENSE
                    : c.map_backend == MapBackend::kSparse ? v1::MAP_BACKEND_SPARSE
                                                           : v1::MAP_BACKEND_UNSPECIFIED);

  v1::GpSpec& g = *spec.mutable_gp();
  g.set_length_scale_m(c.gp.length_scale_m);
  g.set_signal_var(c.gp.signal_var);
  g.set_noise_var(c.gp.noise_var);
  if (c.prior_map == nullptr) {
    g.set_prior_mean(c.gp.prior_mean);
  } else {
    v1::PriorMap& m = *g.mutable_prior_map();
    m.set_units(c.prior_map_units == PriorMapUnits::kProbability ? v1::PRIOR_MAP_UNITS_PROBABILITY
                                                                 : v1::PRIOR_MAP_UNITS_LABEL_MEAN);
    m.mutable_values()->Assign(c.prior_map->data(), c.prior_map->data() + c.prior_map->size());
  }

  const PlannerCommon& common = c.planner.common;
  WriteSensor(c.camera, c.noise, *spec.mutable_sensor());

  v1::FlightSpec& fl = *spec.mutable_flight();
  fl.set_min_altitude_m(c.min_altitude_m);
  fl.set_max_altitude_m(c.max_altitude_m);
  WriteLimits(common.limits, fl);
  fl.set_esdf_voxel_m(c.esdf.voxel_size_m);
  fl.set_esdf_truncation_m(c.esdf.truncation_m);

  v1::PlannerSpec& p = *spec.mutable_planner();
  p.set_kind(PlannerKindToProto(c.planner.kind));
  p.set_seed(common.seed);
  p.set_num_waypoints(c.planner.oaipp.num_waypoints);
  p.set_population(c.planner.oaipp.population);
  p.set_generations(c.planner.oaipp.generations);
  p.set_stall_generations(c.planner.oaipp.stall_generations);
  p.set_stall_tolerance(c.planner.oaipp.stall_tolerance);
  p.set_kappa(common.information.kappa);
  p.set_h_opt_m(common.information.h_opt_m);
  p.set_sigma1_m(common.information.sigma1_m);
  p.set_h_sat_m(common.information.h_sat_m);
  p.set_confirmation_weight(common.information.confirmation_weight);
  p.set_decision_threshold(common.information.decision_threshold);
  p.set_confirmation_phase_s(common.information.confirmation_phase_s);
  p.set_confirmation_phase_weight(common.information.confirmation_phase_weight);
  p.set_ambiguity_margin(common.information.ambiguity_margin);
  p.set_second_look_weight(common.information.second_look_weight);
  p.set_second_look_sharpness(common.information.second_look_sharpness);
  p.set_confirmation_preposterior(common.information.confirmation_preposterior);
  p.set_detection_discount(common.information.detection_discount);
  p.set_lawnmower_altitude_m(c.planner.lawnmower.altitude_m);
  p.set_lawnmower_start_corner(c.planner.lawnmower.start_corner);

  for (const Obstacle& o : c.obstacles) *spec.add_obstacles() = ObstacleToProto(o);
  if (c.search_area != nullptr) internal::WriteSearchAreas(c.search_area->polygons, &spec);
  internal::WriteAirspace(c.airspace, &spec);
  *spec.mutable_start() = UavStateToProto(c.start);
  if (!c.team.empty()) {
    for (const TeamMember& m : c.team) {
      v1::TeamMember& out = *spec.add_team();
      out.set_uav_id(m.uav_id);
      *out.mutable_start() = UavStateToProto(m.start);
      WriteSensor(m.kit.camera, m.kit.noise, *out.mutable_sensor());
      WriteLimits(m.kit.limits, *out.mutable_flight());
    }
    spec.set_min_separation_m(c.min_separation_m);
    spec.set_count_teammate_shots(c.count_teammate_shots);
    spec.set_silent_after_s(c.silent_after_s);
  }
  spec.set_budget_s(c.budget_s);
  internal::WriteHome(c, &spec);
  if (c.geo_origin.has_value()) *spec.mutable_geo_origin() = GeoPointToProto(*c.geo_origin);
  return spec;
}

}  // namespace oaipp::api
