// A MissionSpec with every field set to a value other than its default,
// shared by the conversion tests (tests/api/convert_test.cc) and the fuzz
// seed writer (fuzz/make_seeds.cc).
#pragma once

#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::examples {

inline v1::MissionSpec CustomSpec() {
  const auto V = [](double x, double y, double z) {
    v1::Vector3 v;
    v.set_x(x);
    v.set_y(y);
    v.set_z(z);
    return v;
  };
  v1::MissionSpec spec;
  spec.set_preset("paper");
  v1::FieldSpec& f = *spec.mutable_field();
  f.set_x_min_m(-10);
  f.set_x_max_m(12);  // 44 cells of 0.5 m
  f.set_y_min_m(-5);
  f.set_y_max_m(7);  // 24 cells
  f.set_resolution_m(0.5);
  v1::GpSpec& g = *spec.mutable_gp();
  g.set_length_scale_m(1.9);
  g.set_signal_var(1.5);
  g.set_noise_var(2.5);
  g.set_prior_mean(0.05);
  v1::SensorSpec& s = *spec.mutable_sensor();
  s.set_fov_x_deg(50);
  s.set_fov_y_deg(70);
  s.set_noise_a_var(0.8);
  s.set_noise_b_per_m(0.07);
  s.set_rate_hz(0.5);
  v1::FlightSpec& fl = *spec.mutable_flight();
  fl.set_min_altitude_m(3);
  fl.set_max_altitude_m(30);
  fl.set_max_speed_m_s(7);
  fl.set_max_accel_m_s2(4);
  fl.set_uav_radius_m(0.8);
  fl.set_tracking_error_m(0.3);
  fl.set_esdf_voxel_m(0.25);
  fl.set_esdf_truncation_m(3);
  v1::PlannerSpec& p = *spec.mutable_planner();
  p.set_kind(v1::PLANNER_KIND_OAIPP_NONADAPTIVE);
  p.set_seed(42);
  p.set_num_waypoints(5);
  p.set_population(20);
  p.set_generations(10);
  p.set_stall_generations(6);
  p.set_stall_tolerance(0.002);
  p.set_kappa(2);
  p.set_confirmation_weight(0);  // the only value the trace objective takes
  p.set_decision_threshold(0.4);
  p.set_confirmation_phase_s(0);           // likewise
  p.set_confirmation_preposterior(false);  // only with a positive confirmation weight
  p.set_confirmation_phase_weight(500);
  p.set_ambiguity_margin(0.2);
  p.set_second_look_weight(40);
  p.set_second_look_sharpness(0.3);
  p.set_detection_discount(0.97);
  p.set_h_opt_m(12);
  p.set_sigma1_m(5);
  p.set_h_sat_m(28);
  p.set_lawnmower_altitude_m(14);
  p.set_lawnmower_start_corner(2);
  v1::Obstacle& tower = *spec.add_obstacles();
  tower.set_id("tower");
  *tower.mutable_box()->mutable_centre_m() = V(2, -1, 13);
  *tower.mutable_box()->mutable_size_m() = V(4, 6, 26);
  tower.mutable_box()->set_yaw_deg(30);
  v1::Obstacle& mast = *spec.add_obstacles();
  mast.set_id("mast");
  *mast.mutable_cylinder()->mutable_centre_m() = V(-6, 3, 10);
  mast.mutable_cylinder()->set_radius_m(0.5);
  mast.mutable_cylinder()->set_height_m(20);
  v1::UavState& start = *spec.mutable_start();
  *start.mutable_position_m() = V(8, 4, 9);
  *start.mutable_velocity_m_s() = V(1, -2, 0.5);
  *start.mutable_acceleration_m_s2() = V(0.1, 0.2, -0.3);
  start.set_mission_time_s(12.5);
  spec.set_budget_s(200);
  return spec;
}

}  // namespace oaipp::examples
