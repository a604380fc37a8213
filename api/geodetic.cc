#include "api/geodetic.h"

#include <cmath>
#include <cstdint>
#include <string>

#include "GeographicLib/LocalCartesian.hpp"
#include "absl/strings/str_cat.h"
#include "api/search_area.h"
#include "core/common/status_macros.h"
#include "core/environment/prism.h"

namespace oaipp::api {
namespace {

// Points further from the origin than this are refused: an ENU frame is a
// local frame, and a point that far is a typo (a swapped coordinate).
constexpr double kMaxDistance_m = 1.0e6;

absl::Status CheckRange(absl::string_view field, absl::string_view name, double value, double lo,
                        double hi) {
  if (!std::isfinite(value) || value < lo || value > hi) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ".", name, ": must be in [", lo, ", ", hi, "], got ", value));
  }
  return absl::OkStatus();
}

// Converts `geo` (named `geo_field`) into *local, unless it is unset; both
// set is an error naming `geo_field`.
// `local` is a getter, not the field itself: taking a mutable pointer to an
// unset field would set it (and the order arguments are computed in is
// unspecified).
template <typename Parent>
absl::Status Resolve(const std::optional<GeoFrame>& frame, Parent* parent,
                     bool (Parent::*has_local_fn)() const, bool (Parent::*has_geo_fn)() const,
                     const v1::GeoPoint& (Parent::*geo_fn)() const,
                     v1::Vector3* (Parent::*local_fn)(), const std::string& geo_field,
                     absl::string_view local_name) {
  const bool has_geo = (parent->*has_geo_fn)();
  const bool has_local = (parent->*has_local_fn)();
  const v1::GeoPoint& geo = (parent->*geo_fn)();
  if (!has_geo) return absl::OkStatus();
  if (has_local) {
    return absl::InvalidArgumentError(
        absl::StrCat(geo_field, ": give ", local_name, " or the geodetic point, not both"));
  }
  if (!frame.has_value()) {
    return absl::InvalidArgumentError(
        absl::StrCat(geo_field, ": the mission has no geo_origin, so give ", local_name));
  }
  OAIPP_ASSIGN_OR_RETURN(const GeoPoint point, GeoPointFromProto(geo, geo_field));
  const Vec3 p_W = frame->ToLocal(point);
  if (!(p_W.norm() <= kMaxDistance_m)) {
    return absl::InvalidArgumentError(
        absl::StrCat(geo_field, ": lies ", std::round(p_W.norm() / 1000.0),
                     " km from geo_origin (at most ", kMaxDistance_m / 1000.0, " km)"));
  }
  v1::Vector3* local = (parent->*local_fn)();
  local->set_x(p_W.x());
  local->set_y(p_W.y());
  local->set_z(p_W.z());
  return absl::OkStatus();
}

// A ring's lat_lon_deg into xy_m on the plane East-North of the origin.
absl::Status ResolveRing(const std::optional<GeoFrame>& frame, v1::Ring* ring,
                         const std::string& field) {
  if (ring->lat_lon_deg().empty()) return absl::OkStatus();
  const std::string geo_field = field + ".lat_lon_deg";
  if (!ring->xy_m().empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(geo_field, ": give xy_m or lat_lon_deg, not both"));
  }
  if (!frame.has_value()) {
    return absl::InvalidArgumentError(
        absl::StrCat(geo_field, ": the mission has no geo_origin, so give xy_m"));
  }
  if (ring->lat_lon_deg_size() % 2 != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(geo_field, ": ", ring->lat_lon_deg_size(),
                     " values; latitude and longitude come in pairs"));
  }
  v1::Ring local;
  local.mutable_xy_m()->Reserve(ring->lat_lon_deg_size());
  for (int i = 0; i + 1 < ring->lat_lon_deg_size(); i += 2) {
    const double lat = ring->lat_lon_deg(i);
    const double lon = ring->lat_lon_deg(i + 1);
    if (!(std::abs(lat) <= 90.0) || !(std::abs(lon) <= 180.0)) {
      return absl::InvalidArgumentError(
          absl::StrCat(geo_field, "[", i, "]: vertex ", i / 2,
                       ": latitude must be in [-90, 90] and longitude in [-180, 180]"));
    }
    const Vec3 p_W = frame->ToLocal({lat, lon, frame->origin().altitude_m});
    if (!(p_W.head<2>().norm() <= kMaxDistance_m)) {
      return absl::InvalidArgumentError(
          absl::StrCat(geo_field, "[", i, "]: vertex ", i / 2, " lies ",
                       std::round(p_W.head<2>().norm() / 1000.0), " km from geo_origin (at most ",
                       kMaxDistance_m / 1000.0, " km)"));
    }
    local.add_xy_m(p_W.x());
    local.add_xy_m(p_W.y());
  }
  ring->Swap(&local);
  return absl::OkStatus();
}

absl::Status ResolveObstacle(const std::optional<GeoFrame>& frame, v1::Obstacle* o,
                             const std::string& field) {
  if (o->has_box()) {
    v1::Box* b = o->mutable_box();
    OAIPP_RETURN_IF_ERROR(Resolve(frame, b, &v1::Box::has_centre_m, &v1::Box::has_centre_geo,
                                  &v1::Box::centre_geo, &v1::Box::mutable_centre_m,
                                  field + ".box.centre_geo", "centre_m"));
    b->clear_centre_geo();
  } else if (o->has_cylinder()) {
    v1::Cylinder* c = o->mutable_cylinder();
    OAIPP_RETURN_IF_ERROR(Resolve(frame, c, &v1::Cylinder::has_centre_m,
                                  &v1::Cylinder::has_centre_geo, &v1::Cylinder::centre_geo,
                                  &v1::Cylinder::mutable_centre_m, field + ".cylinder.centre_geo",
                                  "centre_m"));
    c->clear_centre_geo();
  } else if (o->has_prism()) {
    v1::Ring* footprint = o->mutable_prism()->mutable_footprint();
    if (footprint->lat_lon_deg_size() > 2 * (kMaxPrismVertices + 1)) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ".prism.footprint.lat_lon_deg: ", footprint->lat_lon_deg_size(),
                       " values, more than ", kMaxPrismVertices, " vertices"));
    }
    OAIPP_RETURN_IF_ERROR(ResolveRing(frame, footprint, field + ".prism.footprint"));
  }
  return absl::OkStatus();
}

// A fence's geodetic ring or circle centre into metres, on the plane
// East-North of the origin.
absl::Status ResolveFence(const std::optional<GeoFrame>& frame, v1::Fence* fence,
                          const std::string& field) {
  if (fence->has_polygon()) {
    if (fence->polygon().lat_lon_deg_size() > 2 * (kMaxPrismVertices + 1)) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ".polygon.lat_lon_deg: ", fence->polygon().lat_lon_deg_size(),
                       " values, more than ", kMaxPrismVertices, " vertices"));
    }
    return ResolveRing(frame, fence->mutable_polygon(), field + ".polygon");
  }
  if (!fence->has_circle() || !fence->circle().has_centre_geo()) return absl::OkStatus();
  v1::Circle* circle = fence->mutable_circle();
  const std::string geo_field = field + ".circle.centre_geo";
  if (circle->x_m() != 0.0 || circle->y_m() != 0.0) {
    return absl::InvalidArgumentError(
        absl::StrCat(geo_field, ": give x_m and y_m or the geodetic point, not both"));
  }
  if (!frame.has_value()) {
    return absl::InvalidArgumentError(
        absl::StrCat(geo_field, ": the mission has no geo_origin, so give x_m and y_m"));
  }
  OAIPP_ASSIGN_OR_RETURN(GeoPoint point, GeoPointFromProto(circle->centre_geo(), geo_field));
  point.altitude_m = frame->origin().altitude_m;
  const Vec3 p_W = frame->ToLocal(point);
  if (!(p_W.head<2>().norm() <= kMaxDistance_m)) {
    return absl::InvalidArgumentError(
        absl::StrCat(geo_field, ": lies ", std::round(p_W.head<2>().norm() / 1000.0),
                     " km from geo_origin (at most ", kMaxDistance_m / 1000.0, " km)"));
  }
  circle->set_x_m(p_W.x());
  circle->set_y_m(p_W.y());
  circle->clear_centre_geo();
  return absl::OkStatus();
}

bool FenceHasGeo(const v1::Fence& fence) {
  return (fence.has_polygon() && !fence.polygon().lat_lon_deg().empty()) ||
         (fence.has_circle() && fence.circle().has_centre_geo());
}

bool ObstacleHasGeo(const v1::Obstacle& o) {
  return (o.has_box() && o.box().has_centre_geo()) ||
         (o.has_cylinder() && o.cylinder().has_centre_geo()) ||
         (o.has_prism() && !o.prism().footprint().lat_lon_deg().empty());
}

// Every geodetic ring of spec->search_areas, after one bound on their size.
absl::Status ResolveSearchAreas(const std::optional<GeoFrame>& frame, v1::MissionSpec* spec,
                                absl::string_view field) {
  std::int64_t values = 0;
  for (const v1::AreaPolygon& polygon : spec->search_areas()) {
    values += polygon.outer().lat_lon_deg_size() + polygon.outer().xy_m_size();
    for (const v1::Ring& hole : polygon.holes()) {
      values += hole.lat_lon_deg_size() + hole.xy_m_size();
    }
  }
  if (values > 2 * static_cast<std::int64_t>(kMaxAreaVertices)) {
    return absl::InvalidArgumentError(absl::StrCat(
        field, ".search_areas: ", values / 2, " vertices in all, more than ", kMaxAreaVertices));
  }
  for (int i = 0; i < spec->search_areas_size(); ++i) {
    v1::AreaPolygon* polygon = spec->mutable_search_areas(i);
    const std::string name = absl::StrCat(field, ".search_areas[", i, "]");
    if (polygon->has_outer()) {
      OAIPP_RETURN_IF_ERROR(ResolveRing(frame, polygon->mutable_outer(), name + ".outer"));
    }
    for (int h = 0; h < polygon->holes_size(); ++h) {
      OAIPP_RETURN_IF_ERROR(
          ResolveRing(frame, polygon->mutable_holes(h), absl::StrCat(name, ".holes[", h, "]")));
    }
  }
  return absl::OkStatus();
}

bool RingHasGeo(const v1::AreaPolygon& polygon) {
  if (!polygon.outer().lat_lon_deg().empty()) return true;
  for (const v1::Ring& hole : polygon.holes()) {
    if (!hole.lat_lon_deg().empty()) return true;
  }
  return false;
}

absl::StatusOr<std::optional<GeoFrame>> FrameOf(const std::optional<GeoPoint>& origin) {
  if (!origin.has_value()) return std::optional<GeoFrame>();
  OAIPP_ASSIGN_OR_RETURN(GeoFrame frame, GeoFrame::FromOrigin(*origin));
  return std::optional<GeoFrame>(std::move(frame));
}

}  // namespace

absl::StatusOr<GeoPoint> GeoPointFromProto(const v1::GeoPoint& point, absl::string_view field) {
  OAIPP_RETURN_IF_ERROR(CheckRange(field, "latitude_deg", point.latitude_deg(), -90.0, 90.0));
  OAIPP_RETURN_IF_ERROR(CheckRange(field, "longitude_deg", point.longitude_deg(), -180.0, 180.0));
  OAIPP_RETURN_IF_ERROR(CheckRange(field, "altitude_m", point.altitude_m(), -12000.0, 100000.0));
  return GeoPoint{point.latitude_deg(), point.longitude_deg(), point.altitude_m()};
}

v1::GeoPoint GeoPointToProto(const GeoPoint& point) {
  v1::GeoPoint out;
  out.set_latitude_deg(point.latitude_deg);
  out.set_longitude_deg(point.longitude_deg);
  out.set_altitude_m(point.altitude_m);
  return out;
}

GeoFrame::GeoFrame(const GeoPoint& origin)
    : origin_(origin),
      enu_(std::make_unique<GeographicLib::LocalCartesian>(
          origin.latitude_deg, origin.longitude_deg, origin.altitude_m)) {}

absl::StatusOr<GeoFrame> GeoFrame::FromOrigin(const GeoPoint& origin) {
  OAIPP_RETURN_IF_ERROR(GeoPointFromProto(GeoPointToProto(origin), "geo_origin").status());
  return GeoFrame(origin);
}

GeoFrame::GeoFrame(const GeoFrame& other) : GeoFrame(other.origin_) {}
GeoFrame& GeoFrame::operator=(const GeoFrame& other) {
  if (this != &other) *this = GeoFrame(other.origin_);
  return *this;
}
GeoFrame::GeoFrame(GeoFrame&&) noexcept = default;
GeoFrame& GeoFrame::operator=(GeoFrame&&) noexcept = default;
GeoFrame::~GeoFrame() = default;

Vec3 GeoFrame::ToLocal(const GeoPoint& point) const {
  Vec3 p;
  enu_->Forward(point.latitude_deg, point.longitude_deg, point.altitude_m, p.x(), p.y(), p.z());
  return p;
}

GeoPoint GeoFrame::ToGeo(const Vec3& p_W) const {
  GeoPoint g;
  enu_->Reverse(p_W.x(), p_W.y(), p_W.z(), g.latitude_deg, g.longitude_deg, g.altitude_m);
  return g;
}

absl::Status ResolveGeoFields(v1::MissionSpec* spec, absl::string_view field) {
  std::optional<GeoPoint> origin;
  if (spec->has_geo_origin()) {
    OAIPP_ASSIGN_OR_RETURN(
        origin, GeoPointFromProto(spec->geo_origin(), absl::StrCat(field, ".geo_origin")));
  }
  OAIPP_ASSIGN_OR_RETURN(const std::optional<GeoFrame> frame, FrameOf(origin));
  for (int i = 0; i < spec->obstacles_size(); ++i) {
    OAIPP_RETURN_IF_ERROR(ResolveObstacle(frame, spec->mutable_obstacles(i),
                                          absl::StrCat(field, ".obstacles[", i, "]")));
  }
  for (int i = 0; i < spec->no_fly_zones_size(); ++i) {
    OAIPP_RETURN_IF_ERROR(ResolveObstacle(frame, spec->mutable_no_fly_zones(i),
                                          absl::StrCat(field, ".no_fly_zones[", i, "]")));
  }
  if (spec->has_fence()) {
    OAIPP_RETURN_IF_ERROR(
        ResolveFence(frame, spec->mutable_fence(), absl::StrCat(field, ".fence")));
  }
  if (spec->has_start()) {
    v1::UavState* s = spec->mutable_start();
    OAIPP_RETURN_IF_ERROR(Resolve(frame, s, &v1::UavState::has_position_m,
                                  &v1::UavState::has_position_geo, &v1::UavState::position_geo,
                                  &v1::UavState::mutable_position_m,
                                  absl::StrCat(field, ".start.position_geo"), "position_m"));
    s->clear_position_geo();
  }
  if (spec->has_home()) {
    v1::Home* h = spec->mutable_home();
    OAIPP_RETURN_IF_ERROR(Resolve(frame, h, &v1::Home::has_position_m, &v1::Home::has_position_geo,
                                  &v1::Home::position_geo, &v1::Home::mutable_position_m,
                                  absl::StrCat(field, ".home.position_geo"), "position_m"));
    h->clear_position_geo();
  }
  for (int i = 0; i < spec->team_size(); ++i) {
    if (!spec->team(i).has_start()) continue;
    v1::UavState* s = spec->mutable_team(i)->mutable_start();
    OAIPP_RETURN_IF_ERROR(
        Resolve(frame, s, &v1::UavState::has_position_m, &v1::UavState::has_position_geo,
                &v1::UavState::position_geo, &v1::UavState::mutable_position_m,
                absl::StrCat(field, ".team[", i, "].start.position_geo"), "position_m"));
    s->clear_position_geo();
  }
  return ResolveSearchAreas(frame, spec, field);
}

absl::Status ResolveGeoFields(const std::optional<GeoPoint>& origin,
                              v1::UpdateObstaclesRequest* request) {
  OAIPP_ASSIGN_OR_RETURN(const std::optional<GeoFrame> frame, FrameOf(origin));
  for (int i = 0; i < request->add_size(); ++i) {
    OAIPP_RETURN_IF_ERROR(
        ResolveObstacle(frame, request->mutable_add(i), absl::StrCat("add[", i, "]")));
  }
  for (int i = 0; i < request->replace_size(); ++i) {
    OAIPP_RETURN_IF_ERROR(
        ResolveObstacle(frame, request->mutable_replace(i), absl::StrCat("replace[", i, "]")));
  }
  return absl::OkStatus();
}

absl::Status ResolveGeoFields(const std::optional<GeoPoint>& origin,
                              v1::AddMeasurementRequest* request) {
  OAIPP_ASSIGN_OR_RETURN(const std::optional<GeoFrame> frame, FrameOf(origin));
  using R = v1::AddMeasurementRequest;
  OAIPP_RETURN_IF_ERROR(Resolve(frame, request, &R::has_camera_position_m,
                                &R::has_camera_position_geo, &R::camera_position_geo,
                                &R::mutable_camera_position_m, "camera_position_geo",
                                "camera_position_m"));
  request->clear_camera_position_geo();
  return absl::OkStatus();
}

absl::Status ResolveGeoFields(const std::optional<GeoPoint>& origin, v1::UavState* state,
                              absl::string_view field) {
  OAIPP_ASSIGN_OR_RETURN(const std::optional<GeoFrame> frame, FrameOf(origin));
  OAIPP_RETURN_IF_ERROR(Resolve(frame, state, &v1::UavState::has_position_m,
                                &v1::UavState::has_position_geo, &v1::UavState::position_geo,
                                &v1::UavState::mutable_position_m,
                                absl::StrCat(field, ".position_geo"), "position_m"));
  state->clear_position_geo();
  return absl::OkStatus();
}

bool HasGeoFields(const v1::UpdateObstaclesRequest& request) {
  for (const v1::Obstacle& o : request.add()) {
    if (ObstacleHasGeo(o)) return true;
  }
  for (const v1::Obstacle& o : request.replace()) {
    if (ObstacleHasGeo(o)) return true;
  }
  return false;
}

bool HasGeoFields(const v1::AddMeasurementRequest& request) {
  return request.has_camera_position_geo();
}

bool HasGeoFields(const v1::MissionSpec& spec) {
  for (const v1::Obstacle& o : spec.obstacles()) {
    if (ObstacleHasGeo(o)) return true;
  }
  for (const v1::TeamMember& m : spec.team()) {
    if (m.has_start() && m.start().has_position_geo()) return true;
  }
  for (const v1::AreaPolygon& polygon : spec.search_areas()) {
    if (RingHasGeo(polygon)) return true;
  }
  for (const v1::Obstacle& zone : spec.no_fly_zones()) {
    if (ObstacleHasGeo(zone)) return true;
  }
  if (spec.has_fence() && FenceHasGeo(spec.fence())) return true;
  if (spec.has_home() && spec.home().has_position_geo()) return true;
  return spec.has_start() && spec.start().has_position_geo();
}

}  // namespace oaipp::api
