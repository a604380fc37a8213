// client/geo_import/: what the reader refuses or skips before any ring
// reaches the mission. A GeoPackage or Shapefile layer without a CRS is an
// error, not degrees; a vertex or a point outside WGS84's ranges is not
// used; a QGIS styles table is not read as features; a multi-part feature's
// parts keep their place when an earlier part is dropped; and a hole may
// meet its outer ring or another hole at one point, as GEOS and the
// server's api/search_area.h allow, but not along an edge.
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "absl/strings/str_join.h"
#include "client/geo_import/geo_import.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/client/geo_import/geo_files.h"

// A namespace of its own: the unity build puts this file beside
// geo_import_test.cc, whose helpers have the same names.
namespace oaipp::client::geo_import::checks {
namespace {

using test_files::ExpectRing;
using test_files::GeoJson;
using test_files::LatLonDeg;
using test_files::MultiPolygon;
using test_files::Point;
using test_files::Polygon;
using test_files::Ring;
using test_files::WriteText;
using test_files::XyFile;
using test_files::XyRing;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::SizeIs;

// (north, east) steps of 1e-4 deg from a field near Zurich.
constexpr LatLonDeg kBase{47.3977, 8.5456};
LatLonDeg At(double north, double east) {
  return {kBase.lat + north * 1e-4, kBase.lon + east * 1e-4};
}
Ring Square(double north, double east, double side) {
  return {At(north, east), At(north, east + side), At(north + side, east + side),
          At(north + side, east)};
}
// The same square as (x, y) = (lon, lat) for a GeoPackage in EPSG:4326.
XyRing XySquare(double north, double east, double side) {
  XyRing out;
  for (const LatLonDeg& v : Square(north, east, side)) out.xy.emplace_back(v.lon, v.lat);
  return out;
}
// A 100 x 80 m block near Zurich in UTM zone 32N, metres.
const XyRing kUtmBlock = {
    .xy = {{465000, 5249000}, {465100, 5249000}, {465100, 5249080}, {465000, 5249080}}};

class GeoImportChecksTest : public test_files::FileFolderTest {
 protected:
  GeoImportChecksTest() : FileFolderTest("geo_import_checks_") {}
  std::string WriteXy(const std::string& name, const XyFile& file) {
    test_files::WriteXyFile(dir_ / name, file);
    return (dir_ / name).string();
  }
};

TEST_F(GeoImportChecksTest, AShapefileWithoutItsPrjIsRefusedNotReadAsDegrees) {
  const XyFile block = {.driver = "ESRI Shapefile",
                        .epsg = 0,
                        .polygons = {{kUtmBlock}},
                        .properties = {{"building", "yes"}, {"height", "9"}},
                        .attribute_rows = 0};
  const std::string bare = WriteXy("bare.shp", block);
  ASSERT_FALSE(std::filesystem::exists(dir_ / "bare.prj"));
  const absl::Status status = ReadBuildings(bare, "search_files.buildings", {}, dropped_).status();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(status.message()), HasSubstr("search_files.buildings: "));
  EXPECT_THAT(std::string(status.message()), HasSubstr("has no coordinate reference system"));

  // With its .prj the same block is read, near Zurich (47.39 N, 8.54 E).
  XyFile with_prj = block;
  with_prj.epsg = 32632;
  const std::string utm = WriteXy("utm.shp", with_prj);
  absl::StatusOr<std::vector<v1::Obstacle>> buildings =
      ReadBuildings(utm, "search_files.buildings", {}, dropped_);
  ASSERT_TRUE(buildings.ok()) << buildings.status();
  ASSERT_THAT(*buildings, SizeIs(1));
  EXPECT_NEAR((*buildings)[0].prism().footprint().lat_lon_deg(0), 47.39, 0.02);
  EXPECT_NEAR((*buildings)[0].prism().footprint().lat_lon_deg(1), 8.54, 0.02);
}

TEST_F(GeoImportChecksTest, AGeoPackageLayerWithAnUndefinedSrsIsRefused) {
  const std::string path = WriteXy("area.gpkg", {.driver = "GPKG",
                                                 .epsg = 0,
                                                 .polygons = {{kUtmBlock}},
                                                 .properties = {},
                                                 .attribute_rows = 0});
  const absl::Status status = ReadSearchArea(path, "search_files.area", dropped_).status();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(status.message()), HasSubstr("search_files.area: "));
  EXPECT_THAT(std::string(status.message()), HasSubstr("has no coordinate reference system"));
}

TEST_F(GeoImportChecksTest, VerticesAndPointsOutsideWgs84AreNotUsed) {
  // GeoJSON is WGS84 by definition: UTM metres written into one are
  // longitudes of 465000, and a polygon near the pole reaching 90.05 N.
  const Ring utm_as_degrees = {{5249000, 465000}, {5249000, 465100}, {5249080, 465100}};
  const Ring past_the_pole = {{89.95, 8.0}, {89.95, 8.1}, {90.05, 8.1}, {90.05, 8.0}};
  const std::string area = Write(
      "area.geojson",
      GeoJson({Polygon({utm_as_degrees}), Polygon({Square(0, 0, 1)}), Polygon({past_the_pole})}));
  absl::StatusOr<std::vector<v1::AreaPolygon>> polygons =
      ReadSearchArea(area, "search_files.area", dropped_);
  ASSERT_TRUE(polygons.ok()) << polygons.status();
  ASSERT_THAT(*polygons, SizeIs(1));
  ExpectRing((*polygons)[0].outer(), Square(0, 0, 1));
  EXPECT_THAT(dropped_,
              ElementsAre("search_files.area: feature 1: its outer ring's vertex 1 (longitude "
                          "465000, latitude 5249000) is not in WGS84's [-180, 180] x [-90, 90] "
                          "degrees; dropped",
                          "search_files.area: feature 3: its outer ring's vertex 3 (longitude "
                          "8.1, latitude 90.05) is not in WGS84's [-180, 180] x [-90, 90] "
                          "degrees; dropped"))
      << absl::StrJoin(dropped_, "\n");

  // A zone's point is checked too, and closed airspace is never dropped.
  const auto zone_error = [&](LatLonDeg at) {
    const std::string path = Write("zones.geojson", GeoJson({Point(at, R"("radius_m": 10)")}));
    return ReadNoFlyZones(path, "search_files.no_fly_zones", 0.0, dropped_).status();
  };
  EXPECT_THAT(zone_error({95.0, 8.5}).message(),
              HasSubstr("search_files.no_fly_zones: feature 1: its point (longitude 8.5, "
                        "latitude 95) is not in WGS84's"));
  EXPECT_THAT(zone_error({47.0, 181.0}).message(),
              HasSubstr("feature 1: its point (longitude 181, latitude 47) is not in WGS84's"));
  // The ranges are closed: the pole and the antimeridian are positions.
  EXPECT_TRUE(zone_error({90.0, 180.0}).ok());
  EXPECT_TRUE(zone_error({-90.0, -180.0}).ok());
}

TEST_F(GeoImportChecksTest, AQgisStylesTableIsNotReadAsFeatures) {
  // Three style rows in an attribute-only table, written before the map's
  // layer, and two buildings in WGS84.
  const std::string path =
      WriteXy("buildings.gpkg", {.driver = "GPKG",
                                 .epsg = 4326,
                                 .polygons = {{XySquare(0, 0, 1)}, {XySquare(0, 2, 1)}},
                                 .properties = {{"building", "yes"}, {"height", "9"}},
                                 .attribute_rows = 3});
  absl::StatusOr<std::vector<v1::Obstacle>> zones =
      ReadNoFlyZones(path, "search_files.no_fly_zones", 0.0, dropped_);
  ASSERT_TRUE(zones.ok()) << zones.status();
  ASSERT_THAT(*zones, SizeIs(2));
  EXPECT_EQ((*zones)[0].id(), "zone-1");
  EXPECT_EQ((*zones)[1].id(), "zone-2");
  ExpectRing((*zones)[1].prism().footprint(), Square(0, 2, 1));

  absl::StatusOr<std::vector<v1::Obstacle>> buildings =
      ReadBuildings(path, "search_files.buildings", {}, dropped_);
  ASSERT_TRUE(buildings.ok()) << buildings.status();
  ASSERT_THAT(*buildings, SizeIs(2));
  EXPECT_EQ((*buildings)[0].id(), "building-1");
  EXPECT_EQ((*buildings)[1].id(), "building-2");

  absl::StatusOr<std::vector<v1::AreaPolygon>> area =
      ReadSearchArea(path, "search_files.area", dropped_);
  ASSERT_TRUE(area.ok()) << area.status();
  EXPECT_THAT(*area, SizeIs(2));
  // No "no geometry" feature and no untagged one was met.
  EXPECT_THAT(dropped_, IsEmpty()) << absl::StrJoin(dropped_, "\n");
}

TEST_F(GeoImportChecksTest, AGeoJsonZoneWithoutGeometryIsStillAnError) {
  const std::string path =
      Write("zones.geojson", R"({"type": "FeatureCollection", "features": [)"
                             R"({"type": "Feature", "properties": {}, "geometry": null}]})");
  EXPECT_THAT(ReadNoFlyZones(path, "search_files.no_fly_zones", 0.0, dropped_).status().message(),
              HasSubstr("search_files.no_fly_zones: feature 1: no geometry"));
}

TEST_F(GeoImportChecksTest, APartKeepsItsPlaceWhenAnEarlierPartIsDropped) {
  // Part 1 crosses itself, part 2 has 300 vertices (over the API's 256),
  // part 3 is usable: it is building-1-3, the third of three.
  const Ring bowtie = {At(5, 0), At(6, 1), At(5, 1), At(6, 0)};
  Ring round;
  for (int i = 0; i < 300; ++i) {
    const double a = 2 * 3.141592653589793 * i / 300;
    round.push_back(At(20 + std::sin(a), 20 + std::cos(a)));
  }
  const std::string path =
      Write("buildings.geojson", GeoJson({MultiPolygon({bowtie, round, Square(0, 0, 1)},
                                                       R"("building": "yes", "height": 9)")}));
  absl::StatusOr<std::vector<v1::Obstacle>> buildings =
      ReadBuildings(path, "search_files.buildings", {}, dropped_);
  ASSERT_TRUE(buildings.ok()) << buildings.status();
  ASSERT_THAT(*buildings, SizeIs(1));
  EXPECT_EQ((*buildings)[0].id(), "building-1-3");
  ExpectRing((*buildings)[0].prism().footprint(), Square(0, 0, 1));
  EXPECT_THAT(dropped_,
              ElementsAre("search_files.buildings: feature 1: polygon 1 of 3: its outer ring "
                          "crosses or touches itself; dropped",
                          "search_files.buildings: feature 1: polygon 2 of 3: its footprint has "
                          "300 vertices, more than the API's 256; dropped"))
      << absl::StrJoin(dropped_, "\n");
}

// Holes against a 4 x 4 outer ring (steps of 1e-4 deg):
//
//   4 +---------------+   at_point: a triangle whose apex is on the bottom
//     |               |     edge at (0, 2)
//     |     /\        |   holes_at_point: squares [1, 2] and [2, 3] that
//     |    /  \       |     share the corner (2, 2)
//   0 +-------*-------+   along_edge: a square [0, 1] x [1, 2] whose side
//     0       2       4     runs along the bottom edge
//                         cut_apart: a diamond through the midpoints of all
//                           four sides, leaving four corners
TEST_F(GeoImportChecksTest, AHoleMayMeetItsRingAtAPointButNotAlongAnEdge) {
  const Ring outer = Square(0, 0, 4);
  const Ring at_point = {At(0, 2), At(1, 3), At(1, 1)};
  const Ring along_edge = Square(0, 1, 1);
  const Ring cut_apart = {At(0, 2), At(2, 4), At(4, 2), At(2, 0)};
  const std::string path =
      Write("area.geojson",
            GeoJson({Polygon({outer, at_point}), Polygon({outer, Square(1, 1, 1), Square(2, 2, 1)}),
                     Polygon({outer, along_edge}), Polygon({outer, cut_apart})}));
  absl::StatusOr<std::vector<v1::AreaPolygon>> area =
      ReadSearchArea(path, "search_files.area", dropped_);
  ASSERT_TRUE(area.ok()) << area.status();
  ASSERT_THAT(*area, SizeIs(2));
  ASSERT_EQ((*area)[0].holes_size(), 1);
  ExpectRing((*area)[0].holes(0), at_point);
  ASSERT_EQ((*area)[1].holes_size(), 2);
  ExpectRing((*area)[1].holes(1), Square(2, 2, 1));
  ASSERT_THAT(dropped_, SizeIs(2));
  EXPECT_THAT(dropped_[0], HasSubstr("feature 3: a hole"));
  EXPECT_THAT(dropped_[1], HasSubstr("feature 4: a hole"));
}

}  // namespace
}  // namespace oaipp::client::geo_import::checks
