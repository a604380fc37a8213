// WGS84 <-> the mission's local frame.
//
// A mission with a geo_origin has its world frame W East-North-Up at that
// origin: x east, y north, z up, metres. GeoFrame converts between the two
// with GeographicLib's LocalCartesian (exact on the WGS84 ellipsoid, not a
// flat-Earth approximation). Altitudes at the API are metres above mean sea
// level and are converted as heights over the ellipsoid: local heights are
// then exact as long as the geoid is flat across the field (it varies by
// centimetres per kilometre).
//
// ResolveGeoFields rewrites the *_geo fields of a request into the local
// fields next to them, so that everything after it (validation, storage,
// replay) sees local metres only.
//
//   OAIPP_ASSIGN_OR_RETURN(GeoFrame frame, GeoFrame::FromOrigin(origin));
//   Vec3 p_W = frame.ToLocal({47.3977, 8.5456, 490.0});
//   OAIPP_RETURN_IF_ERROR(ResolveGeoFields(config.geo_origin, &request));
#pragma once

#include <memory>
#include <optional>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "api/mission_config.h"
#include "core/common/geometry.h"
#include "oaipp/v1/mission_service.pb.h"

namespace GeographicLib {
class LocalCartesian;
}

namespace oaipp::api {

// A point given at the API: latitude in [-90, 90], longitude in [-180, 180],
// altitude finite and within [-12000, 100000] m. InvalidArgument naming
// `field` + ".latitude_deg" etc. otherwise.
[[nodiscard]] absl::StatusOr<GeoPoint> GeoPointFromProto(const v1::GeoPoint& point,
                                                         absl::string_view field);
[[nodiscard]] v1::GeoPoint GeoPointToProto(const GeoPoint& point);

class GeoFrame {
 public:
  // The ENU frame at `origin` (checked as GeoPointFromProto does, the field
  // named "geo_origin").
  [[nodiscard]] static absl::StatusOr<GeoFrame> FromOrigin(const GeoPoint& origin);
  GeoFrame(const GeoFrame& other);
  GeoFrame& operator=(const GeoFrame& other);
  GeoFrame(GeoFrame&&) noexcept;
  GeoFrame& operator=(GeoFrame&&) noexcept;
  ~GeoFrame();

  [[nodiscard]] const GeoPoint& origin() const { return origin_; }
  // Geodetic -> local ENU metres.
  [[nodiscard]] Vec3 ToLocal(const GeoPoint& point) const;
  // Local ENU metres -> geodetic (altitude above mean sea level).
  [[nodiscard]] GeoPoint ToGeo(const Vec3& p_W) const;

 private:
  explicit GeoFrame(const GeoPoint& origin);
  GeoPoint origin_;
  std::unique_ptr<GeographicLib::LocalCartesian> enu_;
};

// Rewrites every *_geo field into the local field next to it (and clears
// it). InvalidArgument naming the field ("spec.obstacles[1].box.centre_geo",
// "state.position_geo", "camera_position_geo", "add[0].cylinder.centre_geo")
// when both forms are given, when a geodetic point is invalid, when a
// converted point lies more than 1000 km from the origin, or when a
// geodetic point is given but the mission has no geo_origin. The spec's own
// geo_origin is validated here too ("spec.geo_origin.latitude_deg"). A
// search area's rings given as lat_lon_deg become xy_m on the plane
// East-North of the origin ("spec.search_areas[0].holes[1].lat_lon_deg[6]"
// names a refused vertex's latitude).
[[nodiscard]] absl::Status ResolveGeoFields(v1::MissionSpec* spec, absl::string_view field);
[[nodiscard]] absl::Status ResolveGeoFields(const std::optional<GeoPoint>& origin,
                                            v1::UpdateObstaclesRequest* request);
[[nodiscard]] absl::Status ResolveGeoFields(const std::optional<GeoPoint>& origin,
                                            v1::AddMeasurementRequest* request);
[[nodiscard]] absl::Status ResolveGeoFields(const std::optional<GeoPoint>& origin,
                                            v1::UavState* state, absl::string_view field);

// Whether a request has any *_geo field set (callers copy it only then).
[[nodiscard]] bool HasGeoFields(const v1::UpdateObstaclesRequest& request);
[[nodiscard]] bool HasGeoFields(const v1::AddMeasurementRequest& request);
[[nodiscard]] bool HasGeoFields(const v1::MissionSpec& spec);

}  // namespace oaipp::api
