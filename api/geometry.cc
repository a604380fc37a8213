#include "api/geometry.h"
#include "api/limits.h"

#include <cmath>
#include <set>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "absl/strings/str_cat.h"
#include "api/internal/checks.h"
#include "core/common/status_macros.h"

namespace oaipp::api {
namespace {

using internal::CheckBoundedVector;
using internal::CheckFiniteVector;
using internal::CheckId;
using internal::CheckNonNegative;
using internal::CheckPositiveAtMost;

double RadToDeg(double rad) { return rad * 180.0 / kPi; }

}  // namespace

v1::Vector3 ToProto(const Vec3& v) {
  v1::Vector3 out;
  out.set_x(v.x());
  out.set_y(v.y());
  out.set_z(v.z());
  return out;
}

Vec3 FromProto(const v1::Vector3& v) { return Vec3(v.x(), v.y(), v.z()); }

absl::StatusOr<Obstacle> ObstacleFromProto(const v1::Obstacle& obstacle, absl::string_view field) {
  OAIPP_RETURN_IF_ERROR(CheckId(absl::StrCat(field, ".id"), obstacle.id()));
  Obstacle out;
  out.id = obstacle.id();
  switch (obstacle.shape_case()) {
    case v1::Obstacle::kBox: {
      const v1::Box& b = obstacle.box();
      const std::string name = absl::StrCat(field, ".box");
      OAIPP_RETURN_IF_ERROR(
          CheckBoundedVector(absl::StrCat(name, ".centre_m"), b.centre_m(), kMaxCoordinateM));
      OAIPP_RETURN_IF_ERROR(
          CheckPositiveAtMost(absl::StrCat(name, ".size_m.x"), b.size_m().x(), kMaxCoordinateM));
      OAIPP_RETURN_IF_ERROR(
          CheckPositiveAtMost(absl::StrCat(name, ".size_m.y"), b.size_m().y(), kMaxCoordinateM));
      OAIPP_RETURN_IF_ERROR(
          CheckPositiveAtMost(absl::StrCat(name, ".size_m.z"), b.size_m().z(), kMaxCoordinateM));
      OAIPP_RETURN_IF_ERROR(CheckFinite(absl::StrCat(name, ".yaw_deg"), b.yaw_deg()));
      out.shape = Box{.centre_W = FromProto(b.centre_m()),
                      .size_m = FromProto(b.size_m()),
                      .yaw_rad = DegToRad(b.yaw_deg())};
      break;
    }
    case v1::Obstacle::kCylinder: {
      const v1::Cylinder& cyl = obstacle.cylinder();
      const std::string name = absl::StrCat(field, ".cylinder");
      OAIPP_RETURN_IF_ERROR(
          CheckBoundedVector(absl::StrCat(name, ".centre_m"), cyl.centre_m(), kMaxCoordinateM));
      OAIPP_RETURN_IF_ERROR(
          CheckPositiveAtMost(absl::StrCat(name, ".radius_m"), cyl.radius_m(), kMaxCoordinateM));
      OAIPP_RETURN_IF_ERROR(
          CheckPositiveAtMost(absl::StrCat(name, ".height_m"), cyl.height_m(), kMaxCoordinateM));
      out.shape = Cylinder{.centre_W = FromProto(cyl.centre_m()),
                           .radius_m = cyl.radius_m(),
                           .height_m = cyl.height_m()};
      break;
    }
    case v1::Obstacle::kPrism: {
      const v1::Prism& p = obstacle.prism();
      const std::string name = absl::StrCat(field, ".prism");
      // Bounded before anything is copied.
      if (p.footprint().xy_m_size() > 2 * (kMaxPrismVertices + 1) ||
          p.footprint().xy_m_size() % 2 != 0) {
        return absl::InvalidArgumentError(
            absl::StrCat(name, ".footprint.xy_m: ", p.footprint().xy_m_size(),
                         " values; x and y pairs of 3..", kMaxPrismVertices, " vertices"));
      }
      std::vector<Vec2> footprint;
      footprint.reserve(static_cast<std::size_t>(p.footprint().xy_m_size() / 2));
      for (int i = 0; i + 1 < p.footprint().xy_m_size(); i += 2) {
        const Vec2 v(p.footprint().xy_m(i), p.footprint().xy_m(i + 1));
        if (!(v.cwiseAbs().maxCoeff() <= kMaxCoordinateM)) {
          return absl::InvalidArgumentError(absl::StrCat(name, ".footprint.xy_m[", i, "]: vertex ",
                                                         i / 2, " must be finite and within ",
                                                         kMaxCoordinateM, " m on each axis"));
        }
        footprint.push_back(v);
      }
      for (const auto& [what, z] :
           {std::pair{"base_m", p.base_m()}, std::pair{"top_m", p.top_m()}}) {
        if (!(std::abs(z) <= kMaxCoordinateM)) {
          return absl::InvalidArgumentError(
              absl::StrCat(name, ".", what, ": must be finite and within ", kMaxCoordinateM, " m"));
        }
      }
      OAIPP_ASSIGN_OR_RETURN(Prism prism,
                             Prism::Create(std::move(footprint), p.base_m(), p.top_m(), name));
      out.shape = std::move(prism);
      break;
    }
    case v1::Obstacle::SHAPE_NOT_SET:
      return absl::InvalidArgumentError(
          absl::StrCat(field, ".shape: must be set (a box, a cylinder or a prism)"));
  }
  // The core's own check, as a backstop.
  OAIPP_RETURN_IF_ERROR(ValidateShape(out.shape, absl::StrCat(field, ".shape")));
  return out;
}

v1::Obstacle ObstacleToProto(const Obstacle& obstacle) {
  v1::Obstacle out;
  out.set_id(obstacle.id);
  if (const Box* b = std::get_if<Box>(&obstacle.shape)) {
    v1::Box& box = *out.mutable_box();
    *box.mutable_centre_m() = ToProto(b->centre_W);
    *box.mutable_size_m() = ToProto(b->size_m);
    box.set_yaw_deg(RadToDeg(b->yaw_rad));
  } else if (const Cylinder* c = std::get_if<Cylinder>(&obstacle.shape)) {
    v1::Cylinder& cyl = *out.mutable_cylinder();
    *cyl.mutable_centre_m() = ToProto(c->centre_W);
    cyl.set_radius_m(c->radius_m);
    cyl.set_height_m(c->height_m);
  } else if (const Prism* p = std::get_if<Prism>(&obstacle.shape)) {
    v1::Prism& prism = *out.mutable_prism();
    for (const Vec2& v : p->footprint()) {
      prism.mutable_footprint()->add_xy_m(v.x());
      prism.mutable_footprint()->add_xy_m(v.y());
    }
    prism.set_base_m(p->base_m());
    prism.set_top_m(p->top_m());
  }
  return out;
}

absl::StatusOr<ObstacleChange> ObstacleChangeFromProto(const v1::UpdateObstaclesRequest& request) {
  ObstacleChange change;
  if (request.add_size() + request.remove_size() + request.replace_size() > kMaxObstacles) {
    return absl::InvalidArgumentError(absl::StrCat(
        "add: ", request.add_size(), " + remove: ", request.remove_size(), " + replace: ",
        request.replace_size(), " obstacles in one change; at most ", kMaxObstacles));
  }
  std::set<std::string> seen;
  const auto note = [&](const std::string& field, const std::string& id) -> absl::Status {
    if (seen.insert(id).second) return absl::OkStatus();
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": id '", id, "' appears more than once in the change"));
  };
  for (int i = 0; i < request.add_size(); ++i) {
    const std::string field = absl::StrCat("add[", i, "]");
    OAIPP_ASSIGN_OR_RETURN(Obstacle o, ObstacleFromProto(request.add(i), field));
    OAIPP_RETURN_IF_ERROR(note(absl::StrCat(field, ".id"), o.id));
    change.add.push_back(std::move(o));
  }
  for (int i = 0; i < request.remove_size(); ++i) {
    const std::string field = absl::StrCat("remove[", i, "]");
    OAIPP_RETURN_IF_ERROR(CheckId(field, request.remove(i)));
    OAIPP_RETURN_IF_ERROR(note(field, request.remove(i)));
    change.remove.push_back(request.remove(i));
  }
  for (int i = 0; i < request.replace_size(); ++i) {
    const std::string field = absl::StrCat("replace[", i, "]");
    OAIPP_ASSIGN_OR_RETURN(Obstacle o, ObstacleFromProto(request.replace(i), field));
    OAIPP_RETURN_IF_ERROR(note(absl::StrCat(field, ".id"), o.id));
    change.replace.push_back(std::move(o));
  }
  return change;
}

absl::StatusOr<UavState> UavStateFromProto(const v1::UavState& state, absl::string_view field) {
  OAIPP_RETURN_IF_ERROR(CheckFiniteVector(absl::StrCat(field, ".position_m"), state.position_m()));
  OAIPP_RETURN_IF_ERROR(
      CheckFiniteVector(absl::StrCat(field, ".velocity_m_s"), state.velocity_m_s()));
  OAIPP_RETURN_IF_ERROR(
      CheckFiniteVector(absl::StrCat(field, ".acceleration_m_s2"), state.acceleration_m_s2()));
  OAIPP_RETURN_IF_ERROR(
      CheckNonNegative(absl::StrCat(field, ".mission_time_s"), state.mission_time_s()));
  UavState out;
  out.position_W = FromProto(state.position_m());
  out.velocity_W_m_s = FromProto(state.velocity_m_s());
  out.accel_W_m_s2 = FromProto(state.acceleration_m_s2());
  out.mission_time_s = state.mission_time_s();
  return out;
}

v1::UavState UavStateToProto(const UavState& state) {
  v1::UavState out;
  *out.mutable_position_m() = ToProto(state.position_W);
  *out.mutable_velocity_m_s() = ToProto(state.velocity_W_m_s);
  *out.mutable_acceleration_m_s2() = ToProto(state.accel_W_m_s2);
  out.set_mission_time_s(state.mission_time_s);
  return out;
}

}  // namespace oaipp::api
