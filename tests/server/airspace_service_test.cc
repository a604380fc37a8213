// The closed airspace through the service (MissionSpec.fence and
// .no_fly_zones; docs/method.md §2.6): in seeded random worlds of a concave
// fence, no-fly cylinders and prisms with floors and ceilings, and
// buildings, every path of OA-IPP, the random planner and the lawnmower
// keeps the body and tracking error (1.5 m) inside the fence and out of
// every zone, by this file's own distances every 0.01 s; a zone hides no
// ground; the fence and zones come back as given, in metres from WGS84
// too; bad ones and starts outside are refused naming the field, and
// nothing is stored.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/server/airspace_geometry.h"
#include "tests/server/service_fixture.h"
#include "tests/server/team_fixture.h"
#include "tests/support/sanitizers.h"

namespace oaipp::server {
namespace {

using ::oaipp::testing::UnlessSanitized;
using testing::AddRandomZones;
using testing::At;
using testing::ClosestToAirspace;
using testing::CreateWithSpec;
using ::testing::HasSubstr;
using testing::InProcessService;
using testing::PlanFor;
using testing::Point;
using testing::RandomFence;

TEST(AirspaceServiceTest, PathsStayInsideTheFenceAndOutOfEveryZone) {
  InProcessService service(RegistryLimits{.max_missions = 16, .max_cells_per_mission = 1600});
  std::mt19937 rng(2026);
  const v1::PlannerKind kinds[] = {v1::PLANNER_KIND_OAIPP, v1::PLANNER_KIND_RANDOM,
                                   v1::PLANNER_KIND_LAWNMOWER};
  int plans = 0;
  const int trials = UnlessSanitized(12);
  for (int trial = 0; trial < trials; ++trial) {
    const Point start{-3.0 + 6.0 * (rng() % 1000) / 1000.0, -3.0 + 6.0 * (rng() % 1000) / 1000.0,
                      10};
    v1::MissionSpec spec = testing::TeamSpec({});
    spec.clear_obstacles();  // the small field's building stands at the centre
    spec.set_preset("");     // the service's defaults: the body's rule, 1.5 m
    spec.clear_min_separation_m();
    *spec.mutable_fence() = RandomFence(rng);
    AddRandomZones(rng, start, spec);
    *spec.mutable_start() = At(start, 0);
    spec.mutable_planner()->set_seed(static_cast<std::uint32_t>(trial + 1));
    spec.mutable_planner()->set_kind(kinds[trial % 3]);
    spec.mutable_planner()->set_generations(10);
    const std::string id = absl::StrCat("fenced-", trial);
    const grpc::Status made = CreateWithSpec(service.stub(), id, spec);
    ASSERT_TRUE(made.ok()) << id << ": " << made.error_message();
    plans += FlyLegs(service.stub(), id, start, 3, [&](const v1::PlanPathResponse& path, int leg) {
      EXPECT_GE(ClosestToAirspace(spec, path), 1.0 + 0.5 - 1e-9) << id << " leg " << leg;
    });
  }
  EXPECT_GE(plans, 2 * trials);
}

v1::GetMapResponse CellsOf(InProcessService& s, const std::string& id) {
  grpc::ClientContext context;
  v1::GetMapRequest request;
  request.set_name("missions/" + id);
  request.set_include_cells(true);
  v1::GetMapResponse map;
  EXPECT_TRUE(s.stub().GetMap(&context, request, &map).ok());
  return map;
}

// A zone over the ground is airspace, not a solid: the cells under it start
// with the variance they have without it, where the cells under a building
// of the same footprint start near-certain.
TEST(AirspaceServiceTest, AZoneHidesNoGround) {
  InProcessService s(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600});
  v1::MissionSpec spec = testing::TeamSpec({});
  spec.clear_obstacles();
  *spec.mutable_start() = At({-10, -10, 10}, 0);
  v1::Obstacle block;
  block.set_id("block");
  v1::Box& box = *block.mutable_box();
  box.mutable_centre_m()->set_x(6);
  box.mutable_centre_m()->set_y(6);
  box.mutable_centre_m()->set_z(10);
  box.mutable_size_m()->set_x(6);
  box.mutable_size_m()->set_y(6);
  box.mutable_size_m()->set_z(20);
  v1::MissionSpec zoned = spec;
  *zoned.add_no_fly_zones() = block;
  v1::MissionSpec built = spec;
  *built.add_obstacles() = block;
  ASSERT_TRUE(CreateWithSpec(s.stub(), "plain", spec).ok());
  ASSERT_TRUE(CreateWithSpec(s.stub(), "zoned", zoned).ok());
  ASSERT_TRUE(CreateWithSpec(s.stub(), "built", built).ok());
  const v1::GetMapResponse plain = CellsOf(s, "plain");
  const v1::GetMapResponse under_zone = CellsOf(s, "zoned");
  const v1::GetMapResponse under_building = CellsOf(s, "built");
  // The cell (6.75, 6.75): row 14, column 14 of 20 x 20 at 1.5 m.
  const int cell = 14 * 20 + 14;
  ASSERT_EQ(plain.variance_size(), 400);
  EXPECT_GT(plain.variance(cell), 0.1);
  EXPECT_EQ(under_zone.variance(cell), plain.variance(cell));
  EXPECT_LT(under_building.variance(cell), 0.01 * plain.variance(cell));
}

// The fence and zones come back in metres as given; from WGS84, where the
// mission's origin puts them.
TEST(AirspaceServiceTest, TheFenceAndZonesComeBackAsGivenAndFromWgs84) {
  InProcessService s(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600});
  v1::MissionSpec spec = testing::TeamSpec({});
  spec.clear_obstacles();
  spec.mutable_geo_origin()->set_latitude_deg(47.0);
  spec.mutable_geo_origin()->set_longitude_deg(8.0);
  spec.mutable_geo_origin()->set_altitude_m(400.0);
  // A circle centred 0.0001 deg north of the origin: 11.1 m on the WGS84
  // ellipsoid at 47 deg (111,2xx m a degree of latitude there).
  v1::Circle& circle = *spec.mutable_fence()->mutable_circle();
  circle.mutable_centre_geo()->set_latitude_deg(47.0001);
  circle.mutable_centre_geo()->set_longitude_deg(8.0);
  circle.set_radius_m(30.0);
  v1::Obstacle zone;
  zone.set_id("hospital");
  for (const double v : {5.0, 5.0, 9.0, 5.0, 9.0, 9.0}) {
    zone.mutable_prism()->mutable_footprint()->add_xy_m(v);
  }
  zone.mutable_prism()->set_base_m(0.0);
  zone.mutable_prism()->set_top_m(100.0);
  *spec.add_no_fly_zones() = zone;
  v1::Mission created;
  const grpc::Status made = CreateWithSpec(s.stub(), "geo", spec, &created);
  ASSERT_TRUE(made.ok()) << made.error_message();
  const v1::Circle& back = created.spec().fence().circle();
  EXPECT_FALSE(back.has_centre_geo());
  EXPECT_NEAR(back.x_m(), 0.0, 1e-6);
  EXPECT_NEAR(back.y_m(), 11.12, 0.01);
  EXPECT_EQ(back.radius_m(), 30.0);
  ASSERT_EQ(created.spec().no_fly_zones_size(), 1);
  EXPECT_EQ(created.spec().no_fly_zones(0).id(), "hospital");
  EXPECT_THAT(created.spec().no_fly_zones(0).prism().footprint().xy_m(),
              ::testing::ElementsAre(5.0, 5.0, 9.0, 5.0, 9.0, 9.0));
}

class AirspaceRefusalTest : public testing::TeamStoreTest {};

TEST_F(AirspaceRefusalTest, BadAirspaceAndStartsOutsideAreRefusedNamingTheField) {
  v1::MissionSpec base = testing::TeamSpec({});
  base.clear_obstacles();
  base.set_preset("");
  base.clear_min_separation_m();
  *base.mutable_start() = At({0, 0, 10}, 0);
  const auto square = [](double half) {
    v1::Fence fence;
    for (const double v : {-half, -half, half, -half, half, half, -half, half}) {
      fence.mutable_polygon()->add_xy_m(v);
    }
    return fence;
  };
  std::vector<Refusal> refusals;
  // What the message says after the field, for the starts.
  std::vector<std::pair<v1::MissionSpec, std::string>> details;
  {
    v1::MissionSpec spec = base;
    *spec.mutable_fence() = square(5);
    spec.mutable_start()->mutable_position_m()->set_x(8);
    refusals.push_back({"a start outside the fence", spec, "spec.start.position_m"});
    details.push_back({spec, "outside the fence"});
  }
  {
    v1::MissionSpec spec = base;
    *spec.mutable_fence() = square(5);
    spec.mutable_start()->mutable_position_m()->set_x(4);
    refusals.push_back({"a start 1 m from the fence", spec, "spec.start.position_m"});
    details.push_back({spec, "is 1 m from the fence"});
  }
  {
    v1::MissionSpec spec = base;
    v1::Obstacle& zone = *spec.add_no_fly_zones();
    zone.set_id("z");
    zone.mutable_cylinder()->mutable_centre_m()->set_z(10);
    zone.mutable_cylinder()->set_radius_m(2);
    zone.mutable_cylinder()->set_height_m(4);
    refusals.push_back({"a start inside a zone", spec, "spec.start.position_m"});
    details.push_back({spec, "inside a no-fly zone"});
  }
  {
    v1::MissionSpec spec = base;
    for (const double v : {-5.0, -5.0, 5.0, 5.0, 5.0, -5.0, -5.0, 5.0}) {
      spec.mutable_fence()->mutable_polygon()->add_xy_m(v);
    }
    refusals.push_back({"a bow-tie fence", spec, "spec.fence.polygon: edges 0 and 2 cross"});
  }
  {
    v1::MissionSpec spec = base;
    spec.mutable_fence();  // no shape
    refusals.push_back({"a fence without a shape", spec, "spec.fence.shape"});
  }
  {
    v1::MissionSpec spec = base;
    spec.mutable_fence()->mutable_circle()->set_radius_m(-3);
    refusals.push_back({"a negative radius", spec, "spec.fence.circle.radius_m"});
  }
  {
    v1::MissionSpec spec = base;
    for (int i = 0; i < 2; ++i) {
      v1::Obstacle& zone = *spec.add_no_fly_zones();
      zone.set_id("twin");
      zone.mutable_cylinder()->mutable_centre_m()->set_x(10);
      zone.mutable_cylinder()->mutable_centre_m()->set_z(10);
      zone.mutable_cylinder()->set_radius_m(1);
      zone.mutable_cylinder()->set_height_m(4);
    }
    refusals.push_back({"a zone id twice", spec, "spec.no_fly_zones[1].id"});
  }
  {
    v1::MissionSpec spec = base;
    v1::Circle& circle = *spec.mutable_fence()->mutable_circle();
    circle.set_radius_m(20);
    circle.mutable_centre_geo()->set_latitude_deg(47.0);
    refusals.push_back({"a WGS84 centre without an origin", spec, "spec.fence.circle.centre_geo"});
  }
  ExpectRefusedAndNothingStored(refusals);
  InProcessService s(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600});
  for (const auto& [spec, detail] : details) {
    const grpc::Status status = CreateWithSpec(s.stub(), "start", spec);
    EXPECT_THAT(status.error_message(), HasSubstr(detail));
  }
}

}  // namespace
}  // namespace oaipp::server
