// api/geodetic.h against numbers computed apart from GeographicLib: the
// WGS84 ellipsoid's published constants put through the textbook
// geodetic -> ECEF -> ENU formulas, and the published lengths of a degree
// of latitude and longitude.
#include "api/geodetic.h"

#include <cmath>
#include <tuple>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "gtest/gtest.h"

namespace oaipp::api {
namespace {

constexpr double kPi = 3.14159265358979323846;
// WGS84 (NIMA TR8350.2): semi-major axis and flattening.
constexpr double kA = 6378137.0;
constexpr double kF = 1.0 / 298.257223563;
constexpr double kE2 = kF * (2.0 - kF);

Vec3 Ecef(double lat_deg, double lon_deg, double h) {
  const double lat = lat_deg * kPi / 180.0;
  const double lon = lon_deg * kPi / 180.0;
  const double n = kA / std::sqrt(1.0 - kE2 * std::sin(lat) * std::sin(lat));
  return {(n + h) * std::cos(lat) * std::cos(lon), (n + h) * std::cos(lat) * std::sin(lon),
          (n * (1.0 - kE2) + h) * std::sin(lat)};
}

// East-North-Up of `p` at `o`, by rotating the ECEF difference.
Vec3 Enu(const GeoPoint& o, const GeoPoint& p) {
  const Vec3 d = Ecef(p.latitude_deg, p.longitude_deg, p.altitude_m) -
                 Ecef(o.latitude_deg, o.longitude_deg, o.altitude_m);
  const double lat = o.latitude_deg * kPi / 180.0;
  const double lon = o.longitude_deg * kPi / 180.0;
  const Vec3 east(-std::sin(lon), std::cos(lon), 0.0);
  const Vec3 north(-std::sin(lat) * std::cos(lon), -std::sin(lat) * std::sin(lon), std::cos(lat));
  const Vec3 up(std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat));
  return {east.dot(d), north.dot(d), up.dot(d)};
}

TEST(GeoFrameTest, MatchesTheEllipsoidFormulasNearTheOrigin) {
  // Zurich (PX4's simulated home), a point in the southern hemisphere and
  // one across the antimeridian from its origin.
  for (const GeoPoint& origin :
       {GeoPoint{47.397742, 8.545594, 488.0}, GeoPoint{-33.8688, 151.2093, 20.0},
        GeoPoint{10.0, 179.9995, 0.0}}) {
    const GeoFrame frame = *GeoFrame::FromOrigin(origin);
    for (const auto& [dlat, dlon, dh] :
         {std::tuple{0.001, 0.002, 15.0}, std::tuple{-0.004, 0.001, 80.0},
          std::tuple{0.0002, -0.003, -5.0}}) {
      const GeoPoint p{origin.latitude_deg + dlat, origin.longitude_deg + dlon,
                       origin.altitude_m + dh};
      const Vec3 expected = Enu(origin, p);
      const Vec3 got = frame.ToLocal(p);
      EXPECT_NEAR((got - expected).norm(), 0.0, 1e-6)
          << "origin " << origin.latitude_deg << ", " << origin.longitude_deg;
      const GeoPoint back = frame.ToGeo(got);
      EXPECT_NEAR(back.latitude_deg, p.latitude_deg, 1e-11);
      EXPECT_NEAR(std::remainder(back.longitude_deg - p.longitude_deg, 360.0), 0.0, 1e-11);
      EXPECT_NEAR(back.altitude_m, p.altitude_m, 1e-6);
    }
  }
}

TEST(GeoFrameTest, ADegreeHasItsPublishedLength) {
  // Lengths of one degree on WGS84 (metres), as tabulated for the ellipsoid:
  // latitude {0: 110574, 45: 111132, 60: 111412}, longitude {0: 111320,
  // 45: 78847, 60: 55800}. A 1e-4 degree step, scaled up, is accurate far
  // beyond the tables' last digit.
  struct Row {
    double lat_deg, per_deg_lat_m, per_deg_lon_m;
  };
  for (const Row& r :
       {Row{0.0, 110574.0, 111320.0}, Row{45.0, 111132.0, 78847.0}, Row{60.0, 111412.0, 55800.0}}) {
    const GeoFrame frame = *GeoFrame::FromOrigin({r.lat_deg, 0.0, 0.0});
    const double north = frame.ToLocal({r.lat_deg + 1e-4, 0.0, 0.0}).y() * 1e4;
    const double east = frame.ToLocal({r.lat_deg, 1e-4, 0.0}).x() * 1e4;
    EXPECT_NEAR(north, r.per_deg_lat_m, 1.5) << "latitude " << r.lat_deg;
    EXPECT_NEAR(east, r.per_deg_lon_m, 1.5) << "latitude " << r.lat_deg;
  }
}

TEST(ResolveGeoFieldsTest, RewritesGeodeticPointsIntoLocalMetres) {
  v1::MissionSpec spec;
  spec.mutable_geo_origin()->set_latitude_deg(47.397742);
  spec.mutable_geo_origin()->set_longitude_deg(8.545594);
  spec.mutable_geo_origin()->set_altitude_m(488.0);
  v1::Obstacle* o = spec.add_obstacles();
  o->set_id("shed");
  v1::GeoPoint* c = o->mutable_box()->mutable_centre_geo();
  c->set_latitude_deg(47.397742 + 0.00005);
  c->set_longitude_deg(8.545594 + 0.00004);
  c->set_altitude_m(492.0);
  ASSERT_TRUE(ResolveGeoFields(&spec, "spec").ok());
  EXPECT_FALSE(spec.obstacles(0).box().has_centre_geo());
  const Vec3 expected =
      Enu({47.397742, 8.545594, 488.0}, {47.397742 + 0.00005, 8.545594 + 0.00004, 492.0});
  EXPECT_NEAR(spec.obstacles(0).box().centre_m().x(), expected.x(), 1e-6);
  EXPECT_NEAR(spec.obstacles(0).box().centre_m().y(), expected.y(), 1e-6);
  EXPECT_NEAR(spec.obstacles(0).box().centre_m().z(), expected.z(), 1e-6);
  // About 3 m east, 5.6 m north, 4 m up.
  EXPECT_NEAR(expected.x(), 3.0, 0.1);
  EXPECT_NEAR(expected.y(), 5.56, 0.1);
}

TEST(ResolveGeoFieldsTest, GeodeticRingsBecomeMetresOnTheOriginsPlane) {
  const GeoPoint origin{47.397742, 8.545594, 488.0};
  v1::MissionSpec spec;
  *spec.mutable_geo_origin() = GeoPointToProto(origin);
  // A triangle of about 75 m x 110 m north-east of the origin, and a hole.
  const std::vector<std::pair<double, double>> outer = {
      {47.3977, 8.5455}, {47.3977, 8.5465}, {47.3987, 8.5460}};
  const std::vector<std::pair<double, double>> hole = {
      {47.3979, 8.5459}, {47.3979, 8.5461}, {47.3981, 8.5460}};
  v1::AreaPolygon& area = *spec.add_search_areas();
  for (const auto& [lat, lon] : outer) {
    area.mutable_outer()->add_lat_lon_deg(lat);
    area.mutable_outer()->add_lat_lon_deg(lon);
  }
  v1::Ring& h = *area.add_holes();
  for (const auto& [lat, lon] : hole) {
    h.add_lat_lon_deg(lat);
    h.add_lat_lon_deg(lon);
  }
  ASSERT_TRUE(HasGeoFields(spec));
  ASSERT_TRUE(ResolveGeoFields(&spec, "spec").ok());
  EXPECT_FALSE(HasGeoFields(spec));
  auto expect_ring = [&](const v1::Ring& ring,
                         const std::vector<std::pair<double, double>>& points) {
    EXPECT_EQ(ring.lat_lon_deg_size(), 0);
    ASSERT_EQ(ring.xy_m_size(), 2 * static_cast<int>(points.size()));
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Vec3 e = Enu(origin, {points[i].first, points[i].second, origin.altitude_m});
      EXPECT_NEAR(ring.xy_m(2 * i), e.x(), 1e-6) << i;
      EXPECT_NEAR(ring.xy_m(2 * i + 1), e.y(), 1e-6) << i;
    }
  };
  expect_ring(spec.search_areas(0).outer(), outer);
  expect_ring(spec.search_areas(0).holes(0), hole);
  // The second vertex is about 75 m east of the first (1e-3 degree of
  // longitude at 47.4 degrees north).
  EXPECT_NEAR(spec.search_areas(0).outer().xy_m(2) - spec.search_areas(0).outer().xy_m(0), 75.4,
              0.2);

  // Refusals name the ring and the value.
  v1::MissionSpec bad;
  *bad.mutable_geo_origin() = GeoPointToProto(origin);
  v1::Ring& r = *bad.add_search_areas()->mutable_outer();
  for (const double v : {47.3977, 8.5455, 47.3977, 8.5465, 97.0, 8.5460}) r.add_lat_lon_deg(v);
  absl::Status s = ResolveGeoFields(&bad, "spec");
  EXPECT_TRUE(absl::StartsWith(s.message(), "spec.search_areas[0].outer.lat_lon_deg[4]: vertex 2"))
      << s;
  r.set_lat_lon_deg(4, 47.3987);
  r.add_xy_m(1.0);
  s = ResolveGeoFields(&bad, "spec");
  EXPECT_TRUE(absl::StartsWith(s.message(),
                               "spec.search_areas[0].outer.lat_lon_deg: give xy_m or lat_lon_deg"))
      << s;
  r.clear_xy_m();
  r.add_lat_lon_deg(47.0);
  s = ResolveGeoFields(&bad, "spec");
  EXPECT_TRUE(absl::StrContains(s.message(), "7 values; latitude and longitude come in pairs"))
      << s;
  bad.clear_geo_origin();
  s = ResolveGeoFields(&bad, "spec");
  EXPECT_TRUE(absl::StrContains(s.message(), "the mission has no geo_origin, so give xy_m")) << s;
}

TEST(ResolveGeoFieldsTest, APrismsGeodeticFootprintBecomesMetres) {
  const GeoPoint origin{47.397742, 8.545594, 488.0};
  v1::MissionSpec spec;
  *spec.mutable_geo_origin() = GeoPointToProto(origin);
  v1::Obstacle& o = *spec.add_obstacles();
  o.set_id("hall");
  o.mutable_prism()->set_base_m(0);
  o.mutable_prism()->set_top_m(12);
  const double corners[][2] = {{47.3978, 8.5457}, {47.3978, 8.5459}, {47.3980, 8.5458}};
  for (const auto& c : corners) {
    o.mutable_prism()->mutable_footprint()->add_lat_lon_deg(c[0]);
    o.mutable_prism()->mutable_footprint()->add_lat_lon_deg(c[1]);
  }
  ASSERT_TRUE(HasGeoFields(spec));
  ASSERT_TRUE(ResolveGeoFields(&spec, "spec").ok());
  const v1::Ring& ring = spec.obstacles(0).prism().footprint();
  EXPECT_EQ(ring.lat_lon_deg_size(), 0);
  ASSERT_EQ(ring.xy_m_size(), 6);
  for (int i = 0; i < 3; ++i) {
    const Vec3 e = Enu(origin, {corners[i][0], corners[i][1], origin.altitude_m});
    EXPECT_NEAR(ring.xy_m(2 * i), e.x(), 1e-6);
    EXPECT_NEAR(ring.xy_m(2 * i + 1), e.y(), 1e-6);
  }
  spec.clear_geo_origin();
  o.mutable_prism()->mutable_footprint()->clear_xy_m();
  o.mutable_prism()->mutable_footprint()->add_lat_lon_deg(47.4);
  EXPECT_TRUE(
      absl::StartsWith(ResolveGeoFields(&spec, "spec").message(),
                       "spec.obstacles[0].prism.footprint.lat_lon_deg: the mission has no"));
}

TEST(ResolveGeoFieldsTest, ErrorsNameTheField) {
  v1::AddMeasurementRequest request;
  request.mutable_camera_position_geo()->set_latitude_deg(47.4);
  // No origin.
  absl::Status s = ResolveGeoFields(std::nullopt, &request);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(absl::StartsWith(s.message(), "camera_position_geo: the mission has no geo_origin"))
      << s;
  // Both forms.
  request.mutable_camera_position_m()->set_z(10.0);
  s = ResolveGeoFields(GeoPoint{47.4, 8.5, 400.0}, &request);
  EXPECT_TRUE(absl::StartsWith(s.message(), "camera_position_geo: give camera_position_m or")) << s;
  // Out of range, and too far from the origin.
  v1::UavState state;
  state.mutable_position_geo()->set_latitude_deg(91.0);
  s = ResolveGeoFields(GeoPoint{47.4, 8.5, 400.0}, &state, "state");
  EXPECT_TRUE(
      absl::StartsWith(s.message(), "state.position_geo.latitude_deg: must be in [-90, 90]"))
      << s;
  state.mutable_position_geo()->set_latitude_deg(-47.4);
  s = ResolveGeoFields(GeoPoint{47.4, 8.5, 400.0}, &state, "state");
  EXPECT_TRUE(absl::StrContains(s.message(), "km from geo_origin")) << s;
  v1::MissionSpec spec;
  spec.mutable_geo_origin()->set_longitude_deg(200.0);
  s = ResolveGeoFields(&spec, "spec");
  EXPECT_TRUE(absl::StartsWith(s.message(), "spec.geo_origin.longitude_deg")) << s;
}

}  // namespace
}  // namespace oaipp::api
