#include "fuzz/fuzz_specs.h"

namespace oaipp::fuzz {

v1::Vector3 V(double x, double y, double z) {
  v1::Vector3 v;
  v.set_x(x);
  v.set_y(y);
  v.set_z(z);
  return v;
}

v1::Obstacle BoxObstacle(const std::string& id, const v1::Vector3& centre, const v1::Vector3& size,
                         double yaw_deg) {
  v1::Obstacle o;
  o.set_id(id);
  *o.mutable_box()->mutable_centre_m() = centre;
  *o.mutable_box()->mutable_size_m() = size;
  o.mutable_box()->set_yaw_deg(yaw_deg);
  return o;
}

v1::MissionSpec FixedMissionSpec() {
  v1::MissionSpec spec;
  v1::FieldSpec& f = *spec.mutable_field();
  f.set_x_min_m(-5);
  f.set_y_min_m(-5);
  f.set_x_max_m(5);
  f.set_y_max_m(5);
  f.set_resolution_m(1);
  v1::FlightSpec& fl = *spec.mutable_flight();
  fl.set_min_altitude_m(2);
  fl.set_max_altitude_m(12);
  fl.set_esdf_voxel_m(0.5);
  fl.set_esdf_truncation_m(1);
  *spec.add_obstacles() = BoxObstacle("tower", V(2, -1, 5), V(2, 2, 10), 30);
  v1::Obstacle& mast = *spec.add_obstacles();
  mast.set_id("mast");
  *mast.mutable_cylinder()->mutable_centre_m() = V(-3, 3, 4);
  mast.mutable_cylinder()->set_radius_m(0.5);
  mast.mutable_cylinder()->set_height_m(8);
  return spec;
}

}  // namespace oaipp::fuzz
