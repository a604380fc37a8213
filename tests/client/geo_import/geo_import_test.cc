// client/geo_import/: map files the test writes from its own geometry
// (GeoJSON and KML as text, a GeoPackage through GDAL) come back as the same
// vertices in WGS84, holes as holes; what cannot be used is dropped with
// its reason; a UTM file lands where GeographicLib puts it.
#include "client/geo_import/geo_import.h"

#include <GeographicLib/UTMUPS.hpp>

#include <filesystem>
#include <string>
#include <vector>

#include "absl/strings/str_join.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/client/geo_import/geo_files.h"

namespace oaipp::client::geo_import {
namespace {

using test_files::ExpectRing;
using test_files::GeoFeature;
using test_files::GeoJson;
using test_files::Kml;
using test_files::KmlPolygon;
using test_files::LatLonDeg;
using test_files::LineString;
using test_files::MultiPolygon;
using test_files::Point;
using test_files::Polygon;
using test_files::Ring;
using test_files::Unclosed;
using test_files::WriteText;
using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::SizeIs;

constexpr double kDegTol = 1e-9;  // about 0.1 mm

// Vertices a few metres apart near Zurich: (north, east) steps of 1e-4 deg
// (11.1 m of latitude, 7.5 m of longitude) from kBase.
constexpr LatLonDeg kBase{47.3977, 8.5456};
LatLonDeg At(double north, double east) {
  return {kBase.lat + north * 1e-4, kBase.lon + east * 1e-4};
}
Ring Square(double north, double east, double side) {
  return {At(north, east), At(north, east + side), At(north + side, east + side),
          At(north + side, east)};
}

// The search area: an L (concave at (1, 2)) with a square hole.
//
//   3 +---+
//     |   |
//   1 |   +-------+
//     | []        |
//   0 +-----------+
//     0   2       4   (east)
const Ring kL = {At(0, 0), At(0, 4), At(1, 4), At(1, 2), At(3, 2), At(3, 0)};
const Ring kHole = {At(0.25, 0.5), At(0.25, 1.5), At(0.75, 1.5), At(0.75, 0.5)};
// Edges (0)-(1) and (2)-(3) cross.
const Ring kBowtie = {At(5, 0), At(6, 1), At(5, 1), At(6, 0)};

class GeoImportTest : public test_files::FileFolderTest {
 protected:
  GeoImportTest() : FileFolderTest("geo_import_") {}
};

TEST_F(GeoImportTest, GeoJsonAreaKeepsItsVerticesItsHoleAndItsConcavity) {
  const std::string path =
      Write("area.geojson", GeoJson({Polygon({kL, kHole}, R"("name": "field")"),
                                     MultiPolygon({Square(10, 0, 1), Square(10, 3, 1)})}));
  absl::StatusOr<std::vector<v1::AreaPolygon>> area =
      ReadSearchArea(path, "search_files.area", dropped_);
  ASSERT_TRUE(area.ok()) << area.status();
  ASSERT_THAT(*area, SizeIs(3));
  // Six vertices, the reflex one at (1, 2) among them: not a hull.
  ExpectRing((*area)[0].outer(), kL);
  ASSERT_EQ((*area)[0].holes_size(), 1);
  ExpectRing((*area)[0].holes(0), kHole);
  ExpectRing((*area)[1].outer(), Square(10, 0, 1));
  ExpectRing((*area)[2].outer(), Square(10, 3, 1));
  EXPECT_THAT(dropped_, IsEmpty());
}

TEST_F(GeoImportTest, KmlAreaKeepsItsVerticesAndItsHole) {
  const std::string path = Write("area.kml", Kml({KmlPolygon("field", {kL, kHole})}));
  absl::StatusOr<std::vector<v1::AreaPolygon>> area =
      ReadSearchArea(path, "search_files.area", dropped_);
  ASSERT_TRUE(area.ok()) << area.status();
  ASSERT_THAT(*area, SizeIs(1));
  ExpectRing((*area)[0].outer(), kL);
  ASSERT_EQ((*area)[0].holes_size(), 1);
  ExpectRing((*area)[0].holes(0), kHole);
}

TEST_F(GeoImportTest, UnusablePolygonsAreDroppedEachWithItsReason) {
  const Ring collinear = {At(20, 0), At(20, 1), At(20, 2)};
  const std::string path =
      Write("area.geojson",
            GeoJson({Polygon({kL}), Polygon({kBowtie}, R"("name": "bowtie")"),
                     Unclosed(Square(8, 0, 1)), Polygon({collinear}), LineString(Square(9, 0, 1)),
                     Polygon({Square(0, 10, 3), Square(1, 11, 4)})}));  // hole outside
  absl::StatusOr<std::vector<v1::AreaPolygon>> area =
      ReadSearchArea(path, "search_files.area", dropped_);
  ASSERT_TRUE(area.ok()) << area.status();
  ASSERT_THAT(*area, SizeIs(1));
  ExpectRing((*area)[0].outer(), kL);
  EXPECT_THAT(
      dropped_,
      ElementsAre(
          "search_files.area: feature 2 (bowtie): its outer ring crosses or touches itself; "
          "dropped",
          AllOf(HasSubstr("search_files.area: feature 3: its outer ring is not closed"),
                HasSubstr("dropped")),
          "search_files.area: feature 4: its outer ring encloses no area (its vertices lie on one "
          "line); dropped",
          "search_files.area: feature 5: a LineString is neither a polygon nor a point; dropped",
          AllOf(HasSubstr("feature 6: a hole"), HasSubstr("dropped"))))
      << absl::StrJoin(dropped_, "\n");
}

TEST_F(GeoImportTest, ReadingTwiceGivesTheSameMessages) {
  const std::string path =
      Write("area.geojson", GeoJson({Polygon({kL, kHole}), Polygon({kBowtie})}));
  std::vector<std::string> again;
  absl::StatusOr<std::vector<v1::AreaPolygon>> a = ReadSearchArea(path, "f", dropped_);
  absl::StatusOr<std::vector<v1::AreaPolygon>> b = ReadSearchArea(path, "f", again);
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a->size(), b->size());
  for (std::size_t i = 0; i < a->size(); ++i) {
    EXPECT_EQ((*a)[i].SerializeAsString(), (*b)[i].SerializeAsString());
  }
  EXPECT_EQ(dropped_, again);
}

TEST_F(GeoImportTest, AProjectedGeoPackageLandsWhereGeographicLibPutsIt) {
  // UTM zone 32N, a concave notch in a 100 x 80 m block near Zurich.
  const std::vector<std::pair<double, double>> utm = {{465000, 5249000},
                                                      {465100, 5249000},
                                                      {465100, 5249080},
                                                      {465050, 5249040},
                                                      {465000, 5249080}};
  test_files::WriteGeoPackage(dir_ / "area.gpkg", 32632, {{{.xy = utm}}});
  absl::StatusOr<std::vector<v1::AreaPolygon>> area =
      ReadSearchArea((dir_ / "area.gpkg").string(), "search_files.area", dropped_);
  ASSERT_TRUE(area.ok()) << area.status();
  ASSERT_THAT(*area, SizeIs(1));
  Ring expected;
  for (const auto& [x, y] : utm) {
    LatLonDeg v;
    GeographicLib::UTMUPS::Reverse(32, true, x, y, v.lat, v.lon);
    expected.push_back(v);
  }
  ExpectRing((*area)[0].outer(), expected);
  // And near Zurich, not somewhere the axes were swapped to.
  EXPECT_NEAR((*area)[0].outer().lat_lon_deg(0), 47.39, 0.02);
  EXPECT_NEAR((*area)[0].outer().lat_lon_deg(1), 8.54, 0.02);
}

TEST_F(GeoImportTest, TheFenceIsTheFilesOnePolygon) {
  const std::string path = Write("fence.geojson", GeoJson({Polygon({kL})}));
  absl::StatusOr<v1::Fence> fence = ReadFence(path, "search_files.fence", dropped_);
  ASSERT_TRUE(fence.ok()) << fence.status();
  ExpectRing(fence->polygon(), kL);

  const std::string two =
      Write("two.geojson", GeoJson({Polygon({kL}), Polygon({Square(10, 0, 1)})}));
  EXPECT_THAT(ReadFence(two, "search_files.fence", dropped_).status().message(),
              HasSubstr("search_files.fence: feature 2: a second polygon"));
  const std::string holed = Write("holed.geojson", GeoJson({Polygon({kL, kHole})}));
  EXPECT_THAT(ReadFence(holed, "search_files.fence", dropped_).status().message(),
              HasSubstr("search_files.fence: the polygon has 1 hole;"));
  const std::string crossed = Write("crossed.geojson", GeoJson({Polygon({kBowtie})}));
  EXPECT_THAT(ReadFence(crossed, "search_files.fence", dropped_).status().message(),
              HasSubstr("search_files.fence: feature 1: its outer ring crosses"));
}

TEST_F(GeoImportTest, NoFlyZonesTakeFloorCeilingAndRadiusFromTheirProperties) {
  const LatLonDeg mast = At(2, 2);
  const std::string path = Write(
      "zones.geojson",
      GeoJson({Polygon({Square(0, 0, 1)}, R"("floor_m": 5, "ceiling_m": 60)"),
               Polygon({Square(2, 0, 1)}), Point(mast, R"("radius_m": 7.5, "ceiling_m": 40)")}));
  absl::StatusOr<std::vector<v1::Obstacle>> zones =
      ReadNoFlyZones(path, "search_files.no_fly_zones", 488.0, dropped_);
  ASSERT_TRUE(zones.ok()) << zones.status();
  ASSERT_THAT(*zones, SizeIs(3));
  EXPECT_EQ((*zones)[0].id(), "zone-1");
  ExpectRing((*zones)[0].prism().footprint(), Square(0, 0, 1));
  EXPECT_EQ((*zones)[0].prism().base_m(), 5.0);
  EXPECT_EQ((*zones)[0].prism().top_m(), 60.0);
  EXPECT_EQ((*zones)[1].prism().base_m(), kDefaultZoneFloorM);
  EXPECT_EQ((*zones)[1].prism().top_m(), kDefaultZoneCeilingM);
  const v1::Cylinder& c = (*zones)[2].cylinder();
  EXPECT_EQ((*zones)[2].id(), "zone-3");
  EXPECT_NEAR(c.centre_geo().latitude_deg(), mast.lat, kDegTol);
  EXPECT_NEAR(c.centre_geo().longitude_deg(), mast.lon, kDegTol);
  // From 0 to 40 m over a field at 488 m: centred 20 m up, 40 m tall.
  EXPECT_DOUBLE_EQ(c.centre_geo().altitude_m(), 508.0);
  EXPECT_EQ(c.height_m(), 40.0);
  EXPECT_EQ(c.radius_m(), 7.5);
  EXPECT_THAT(dropped_, IsEmpty());
}

TEST_F(GeoImportTest, AMultiPartZoneGetsAnIdPerPartAndItsHoleClosed) {
  const std::string path =
      Write("zones.geojson",
            GeoJson({Polygon({Square(0, 0, 1)}), MultiPolygon({Square(0, 4, 1), Square(0, 6, 1)}),
                     Polygon({kL, kHole}, R"("name": "range")")}));
  absl::StatusOr<std::vector<v1::Obstacle>> zones =
      ReadNoFlyZones(path, "search_files.no_fly_zones", 0.0, dropped_);
  ASSERT_TRUE(zones.ok()) << zones.status();
  ASSERT_THAT(*zones, SizeIs(4));
  EXPECT_EQ((*zones)[0].id(), "zone-1");
  EXPECT_EQ((*zones)[1].id(), "zone-2-1");
  EXPECT_EQ((*zones)[2].id(), "zone-2-2");
  ExpectRing((*zones)[2].prism().footprint(), Square(0, 6, 1));
  EXPECT_EQ((*zones)[3].id(), "zone-3");
  ExpectRing((*zones)[3].prism().footprint(), kL);  // the outer ring, hole closed
  EXPECT_THAT(dropped_, ElementsAre("search_files.no_fly_zones: feature 3 (range): its 1 hole is "
                                    "closed (a zone is a prism without holes)"));
}

TEST_F(GeoImportTest, AKmlNoFlyZoneReadsItsExtendedData) {
  const std::string path = Write(
      "zones.kml",
      Kml({KmlPolygon("helipad", {Square(0, 0, 1)}, {{"floor_m", "10"}, {"ceiling_m", "45.5"}})}));
  absl::StatusOr<std::vector<v1::Obstacle>> zones =
      ReadNoFlyZones(path, "search_files.no_fly_zones", 488.0, dropped_);
  ASSERT_TRUE(zones.ok()) << zones.status();
  ASSERT_THAT(*zones, SizeIs(1));
  ExpectRing((*zones)[0].prism().footprint(), Square(0, 0, 1));
  EXPECT_EQ((*zones)[0].prism().base_m(), 10.0);
  EXPECT_EQ((*zones)[0].prism().top_m(), 45.5);
}

TEST_F(GeoImportTest, AZoneThatCannotBeReadIsAnErrorNotADrop) {
  const auto error = [&](const std::vector<GeoFeature>& features) {
    const std::string path = Write("zones.geojson", GeoJson(features));
    return std::string(
        ReadNoFlyZones(path, "search_files.no_fly_zones", 0.0, dropped_).status().message());
  };
  EXPECT_THAT(error({Polygon({kBowtie})}),
              HasSubstr("search_files.no_fly_zones: feature 1: its outer ring crosses"));
  EXPECT_THAT(error({Polygon({kL}, R"("floor_m": 30, "ceiling_m": 20)")}),
              HasSubstr("feature 1: ceiling_m 20 is not above floor_m 30"));
  EXPECT_THAT(error({Polygon({kL}, R"("floor_m": "low")")}),
              HasSubstr("feature 1: floor_m 'low' is not a number"));
  EXPECT_THAT(error({Point(At(0, 0))}), HasSubstr("feature 1: a Point needs a radius_m property"));
}

// OSM-tagged footprints, as an Overpass export writes them.
TEST_F(GeoImportTest, BuildingsTakeTheirHeightFromTheirTags) {
  Ring round;  // 300 vertices: over the API's 256
  for (int i = 0; i < 300; ++i) {
    const double a = 2 * 3.141592653589793 * i / 300;
    round.push_back(At(20 + std::sin(a), 20 + std::cos(a)));
  }
  const std::string path = Write(
      "buildings.geojson",
      GeoJson(
          {Polygon({Square(0, 0, 1)}, R"("@id": "way/101", "building": "yes", "height": "12.5 m")"),
           Polygon({Square(0, 2, 1)},
                   R"("@id": "way/102", "building": "house", "building:levels": "5")"),
           Polygon({Square(0, 4, 1)}, R"("@id": "way/103", "building": "shed")"),
           Polygon({Square(0, 6, 1)}, R"("@id": "way/104", "amenity": "parking")"),
           Polygon({round}, R"("@id": "way/105", "building": "silo", "height": 30)"),
           Polygon({kBowtie}, R"("@id": "way/106", "building": "yes")"),
           Polygon(
               {Square(0, 8, 1)},
               R"("@id": "way/107", "building": "yes", "height": "40'", "building:levels": "2")"),
           Polygon({Square(0, 10, 1)}, R"("building": "no")")}));
  absl::StatusOr<std::vector<v1::Obstacle>> buildings =
      ReadBuildings(path, "search_files.buildings", {}, dropped_);
  ASSERT_TRUE(buildings.ok()) << buildings.status();
  ASSERT_THAT(*buildings, SizeIs(4));
  const auto expect = [&](int i, const std::string& id, const Ring& footprint, double top_m) {
    const v1::Obstacle& b = (*buildings)[i];
    EXPECT_EQ(b.id(), id);
    ExpectRing(b.prism().footprint(), footprint);
    EXPECT_EQ(b.prism().base_m(), 0.0) << id;
    EXPECT_DOUBLE_EQ(b.prism().top_m(), top_m) << id;
  };
  expect(0, "building-1", Square(0, 0, 1), 12.5);     // height
  expect(1, "building-2", Square(0, 2, 1), 5 * 3.0);  // 5 levels of 3 m
  expect(2, "building-3", Square(0, 4, 1), 10.0);     // the default
  expect(3, "building-7", Square(0, 8, 1), 2 * 3.0);  // feet: levels instead
  EXPECT_THAT(
      dropped_,
      ElementsAre(
          "search_files.buildings: feature 3 (way/103): building-3: default height 10 m (no "
          "height or building:levels tag)",
          "search_files.buildings: feature 5 (way/105): its footprint has 300 vertices, more "
          "than the API's 256; dropped",
          "search_files.buildings: feature 6 (way/106): its outer ring crosses or touches "
          "itself; dropped",
          "search_files.buildings: feature 7 (way/107): building-7: height 6 m from "
          "building:levels (height '40?' is not metres in (0, 1000])",
          "search_files.buildings: 2 features without a building tag skipped (the first: "
          "feature 4)"))
      << absl::StrJoin(dropped_, "\n");
}

TEST_F(GeoImportTest, OtherRulesForLevelsAndTheDefault) {
  const std::string path =
      Write("buildings.geojson",
            GeoJson({Polygon({Square(0, 0, 1)}, R"("building": "yes", "building:levels": 4)"),
                     Polygon({Square(0, 2, 1)}, R"("building": "yes")")}));
  absl::StatusOr<std::vector<v1::Obstacle>> buildings =
      ReadBuildings(path, "b", {.metres_per_level = 2.5, .default_height_m = 20.0}, dropped_);
  ASSERT_TRUE(buildings.ok()) << buildings.status();
  ASSERT_THAT(*buildings, SizeIs(2));
  EXPECT_DOUBLE_EQ((*buildings)[0].prism().top_m(), 10.0);
  EXPECT_DOUBLE_EQ((*buildings)[1].prism().top_m(), 20.0);
}

TEST(OsmHeightTest, MetresAsOsmWritesThem) {
  EXPECT_EQ(ParseOsmMetres("12"), 12.0);
  EXPECT_EQ(ParseOsmMetres("12.5"), 12.5);
  EXPECT_EQ(ParseOsmMetres("12 m"), 12.0);
  EXPECT_EQ(ParseOsmMetres(" 7m "), 7.0);
  EXPECT_EQ(ParseOsmMetres("40'"), std::nullopt);
  EXPECT_EQ(ParseOsmMetres("12 ft"), std::nullopt);
  EXPECT_EQ(ParseOsmMetres("tall"), std::nullopt);
  EXPECT_EQ(ParseOsmMetres("0"), std::nullopt);
  EXPECT_EQ(ParseOsmMetres("-3"), std::nullopt);
  EXPECT_EQ(ParseOsmMetres("nan"), std::nullopt);
  EXPECT_EQ(ParseOsmMetres("inf m"), std::nullopt);
}

TEST_F(GeoImportTest, ErrorsNameTheFieldAndQuoteNoMoreThanABoundedPiece) {
  std::vector<std::string> dropped;
  absl::Status missing =
      ReadSearchArea((dir_ / "nowhere.geojson").string(), "search_files.area", dropped).status();
  EXPECT_EQ(missing.code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(missing.message(), HasSubstr("search_files.area: no file "));

  const std::string junk = Write("junk.geojson", std::string(100000, '{'));
  absl::Status unreadable = ReadBuildings(junk, "search_files.buildings", {}, dropped).status();
  EXPECT_EQ(unreadable.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(unreadable.message(), HasSubstr("search_files.buildings: "));
  EXPECT_LT(unreadable.message().size(), 600u);

  const std::string points = Write("points.geojson", GeoJson({Point(At(0, 0))}));
  absl::Status no_polygon = ReadSearchArea(points, "search_files.area", dropped).status();
  EXPECT_EQ(no_polygon.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(no_polygon.message(), HasSubstr("has no usable polygon"));

  // A name of 10,000 characters is cut in the dropped line.
  const std::string long_name =
      Write("long.geojson",
            GeoJson({Polygon({kL}),
                     Polygon({kBowtie}, "\"name\": \"" + std::string(10000, 'x') + "\"")}));
  dropped.clear();
  ASSERT_TRUE(ReadSearchArea(long_name, "search_files.area", dropped).ok());
  ASSERT_THAT(dropped, SizeIs(1));
  EXPECT_LT(dropped[0].size(), 200u);
  EXPECT_THAT(dropped[0], HasSubstr("xxx...)"));
}

}  // namespace
}  // namespace oaipp::client::geo_import
