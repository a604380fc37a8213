// Scenario.search_files through the client's loader (client/cli/
// search_files.h): paths from the scenario's folder, the mission filled and
// the field cleared, each bad input an error naming its field; and the
// committed demo passes the server's own validation of a mission spec.
#include "client/cli/search_files.h"

#include <filesystem>
#include <string>
#include <vector>

#include "absl/strings/str_join.h"
#include "api/spec.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "sim/scenario.h"
#include "tests/client/geo_import/geo_files.h"

namespace oaipp::client::cli {
namespace {

using geo_import::test_files::GeoFeature;
using geo_import::test_files::GeoJson;
using geo_import::test_files::Point;
using geo_import::test_files::Polygon;
using geo_import::test_files::Ring;
using geo_import::test_files::WriteText;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::SizeIs;

constexpr char kDemo[] = OAIPP_SCENARIO_DIR "/search-files-demo.json";

// A 10 x 10 m square's corners around (lat, lon), about 1e-4 deg a side.
Ring Square(double lat, double lon) {
  return {{lat, lon}, {lat, lon + 1.3e-4}, {lat + 0.9e-4, lon + 1.3e-4}, {lat + 0.9e-4, lon}};
}

class SearchFilesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::path(::testing::TempDir()) /
           ("search_files_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    std::filesystem::create_directories(dir_ / "maps");
    scenario_path_ = (dir_ / "scenario.json").string();
    v1::GeoPoint& origin = *scenario_.mutable_mission()->mutable_geo_origin();
    origin.set_latitude_deg(47.3977);
    origin.set_longitude_deg(8.5456);
    origin.set_altitude_m(488.0);
  }
  void Write(const std::string& name, const std::vector<GeoFeature>& features) {
    WriteText(dir_ / name, GeoJson(features));
  }
  absl::Status Read() { return ReadSearchFiles(scenario_, scenario_path_, dropped_); }

  std::filesystem::path dir_;
  std::string scenario_path_;
  v1::Scenario scenario_;
  std::vector<std::string> dropped_;
};

TEST_F(SearchFilesTest, FilesFromTheScenariosFolderFillTheMission) {
  Write("maps/area.geojson", {Polygon({Square(47.3970, 8.5450)})});
  Write("maps/fence.geojson", {Polygon({Square(47.3960, 8.5440)})});
  Write("maps/zones.geojson", {Polygon({Square(47.3980, 8.5460)})});
  Write("maps/buildings.geojson",
        {Polygon({Square(47.3990, 8.5470)}, R"("building": "yes", "height": 8)")});
  v1::SearchFiles& files = *scenario_.mutable_search_files();
  files.set_area("maps/area.geojson");
  files.set_fence("maps/fence.geojson");
  files.set_no_fly_zones("maps/zones.geojson");
  files.set_buildings((dir_ / "maps/buildings.geojson").string());  // absolute
  scenario_.mutable_mission()->add_obstacles()->set_id("tower");
  ASSERT_TRUE(Read().ok()) << Read();
  EXPECT_FALSE(scenario_.has_search_files());
  const v1::MissionSpec& m = scenario_.mission();
  ASSERT_THAT(m.search_areas(), SizeIs(1));
  EXPECT_EQ(m.search_areas(0).outer().lat_lon_deg(0), 47.3970);
  EXPECT_EQ(m.fence().polygon().lat_lon_deg(1), 8.5440);
  ASSERT_THAT(m.no_fly_zones(), SizeIs(1));
  EXPECT_EQ(m.no_fly_zones(0).id(), "zone-1");
  // The scenario's own obstacle first, then the file's.
  ASSERT_THAT(m.obstacles(), SizeIs(2));
  EXPECT_EQ(m.obstacles(0).id(), "tower");
  EXPECT_EQ(m.obstacles(1).id(), "building-1");
  EXPECT_EQ(m.obstacles(1).prism().top_m(), 8.0);
  EXPECT_THAT(dropped_, IsEmpty());
}

TEST_F(SearchFilesTest, EachBadInputNamesItsField) {
  const auto error = [&](void (*set)(v1::Scenario&)) {
    v1::Scenario saved = scenario_;
    set(scenario_);
    const absl::Status status = Read();
    scenario_ = saved;
    return status;
  };
  Write("maps/area.geojson", {Polygon({Square(47.3970, 8.5450)})});
  Write("maps/points.geojson", {Point({47.3970, 8.5450})});
  Write("maps/two.geojson",
        {Polygon({Square(47.3970, 8.5450)}), Polygon({Square(47.3980, 8.5450)})});
  WriteText(dir_ / "maps/notes.txt", "not a map\n");

  absl::Status s = error([](v1::Scenario& sc) { sc.mutable_search_files()->set_area("nope.kml"); });
  EXPECT_EQ(s.code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(s.message(), HasSubstr("scenario.json: search_files.area: no file "));

  s = error([](v1::Scenario& sc) { sc.mutable_search_files()->set_buildings("maps/notes.txt"); });
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("search_files.buildings: "));
  EXPECT_THAT(s.message(), HasSubstr("is not a GeoJSON, KML, GeoPackage or Shapefile file"));

  s = error([](v1::Scenario& sc) {
    sc.mutable_mission()->clear_geo_origin();
    sc.mutable_search_files()->set_area("maps/area.geojson");
  });
  EXPECT_THAT(s.message(), HasSubstr("search_files: mission.geo_origin is not set"));

  s = error([](v1::Scenario& sc) { sc.mutable_search_files()->set_area("maps/points.geojson"); });
  EXPECT_THAT(s.message(), HasSubstr("search_files.area: "));
  EXPECT_THAT(s.message(), HasSubstr("has no usable polygon"));

  s = error([](v1::Scenario& sc) { sc.mutable_search_files()->set_fence("maps/two.geojson"); });
  EXPECT_THAT(s.message(), HasSubstr("search_files.fence: feature 2: a second polygon"));

  s = error([](v1::Scenario& sc) {
    sc.mutable_search_files()->set_area("maps/area.geojson");
    sc.mutable_mission()->add_search_areas();
  });
  EXPECT_THAT(s.message(), HasSubstr("search_files.area: not with mission.search_areas"));

  s = error([](v1::Scenario& sc) {
    sc.mutable_search_files()->set_no_fly_zones("maps/area.geojson");
    sc.mutable_mission()->add_obstacles()->set_id("zone-1");
  });
  EXPECT_THAT(s.message(), HasSubstr("search_files.no_fly_zones: id zone-1 is already"));

  s = error([](v1::Scenario& sc) {
    sc.mutable_search_files()->set_buildings("maps/area.geojson");
    sc.mutable_search_files()->set_metres_per_level(0);
  });
  EXPECT_THAT(s.message(), HasSubstr("search_files.metres_per_level: must be > 0"));

  s = error([](v1::Scenario& sc) {
    sc.mutable_search_files()->set_buildings("maps/area.geojson");
    sc.mutable_search_files()->set_default_building_height_m(-1);
  });
  EXPECT_THAT(s.message(), HasSubstr("search_files.default_building_height_m: must be > 0"));
}

TEST_F(SearchFilesTest, BuildingsPastTheApisObstacleLimitAreAnError) {
  // 999 houses on a 32 x 32 grid of 10 m squares, 20 m apart.
  std::vector<GeoFeature> houses;
  for (int i = 0; i < 999; ++i) {
    houses.push_back(Polygon({Square(47.39 + 1.8e-4 * (i / 32), 8.54 + 2.6e-4 * (i % 32))},
                             R"("building": "yes", "height": 8)"));
  }
  Write("maps/buildings.geojson", houses);
  scenario_.mutable_search_files()->set_buildings("maps/buildings.geojson");
  scenario_.mutable_mission()->add_obstacles()->set_id("tower");
  const v1::Scenario one_own = scenario_;
  scenario_.mutable_mission()->add_obstacles()->set_id("mast");
  // 999 and 2 are 1001, one more than the API's 1000 obstacles of a mission
  // (docs/limits.md).
  const absl::Status over = Read();
  EXPECT_EQ(over.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(over.message(), HasSubstr("search_files.buildings: 999 buildings and the mission's "
                                        "2 obstacles make 1001 obstacles; a mission has at most "
                                        "1000"));
  // 999 and 1 fit exactly.
  scenario_ = one_own;
  ASSERT_TRUE(Read().ok()) << Read();
  EXPECT_THAT(scenario_.mission().obstacles(), SizeIs(1000));
}

TEST_F(SearchFilesTest, TheDemoPassesTheServersValidationWithItsBuildings) {
  absl::StatusOr<v1::Scenario> demo = sim::LoadScenarioFile(kDemo);
  ASSERT_TRUE(demo.ok()) << demo.status();
  ASSERT_TRUE(ReadSearchFiles(*demo, kDemo, dropped_).ok());
  const v1::MissionSpec& m = demo->mission();
  EXPECT_THAT(m.obstacles(), SizeIs(53));  // 52 lots and the school (make_search_files_demo.py)
  ASSERT_THAT(m.search_areas(), SizeIs(1));
  EXPECT_THAT(m.search_areas(0).holes(), SizeIs(1));  // the pond
  ASSERT_THAT(m.no_fly_zones(), SizeIs(2));           // from the KML: the helipad and the mast
  EXPECT_EQ(m.no_fly_zones(0).prism().top_m(), 60.0);
  EXPECT_EQ(m.no_fly_zones(1).cylinder().radius_m(), 4.0);
  EXPECT_TRUE(m.has_fence());
  // What the server does first with a spec: geodetic rings to metres,
  // then every check (rings simple, holes inside, the start clear).
  absl::StatusOr<api::MissionConfig> config = api::MissionSpecToConfig(m);
  ASSERT_TRUE(config.ok()) << config.status();
  for (const v1::Obstacle& o : m.obstacles()) {
    EXPECT_LT(o.prism().top_m(), config->max_altitude_m) << o.id() << " leaves no room above";
  }
  // The courtyard, the car park and the untagged houses are listed.
  EXPECT_THAT(absl::StrJoin(dropped_, "\n"),
              HasSubstr("relation/77): building-53: its 1 hole (a courtyard) is closed"));
  EXPECT_THAT(absl::StrJoin(dropped_, "\n"), HasSubstr("1 feature without a building tag"));
  EXPECT_THAT(absl::StrJoin(dropped_, "\n"), HasSubstr("default height 10 m"));
}

}  // namespace
}  // namespace oaipp::client::cli
