// Missions with a search area (MissionSpec.search_areas; docs/method.md
// §6.7) through the service: the area and its cells as GetMission and GetMap
// answer them, against a mask worked out here from the drawing, before and
// after a restart (from the log and from a snapshot); refusals that name
// the ring and store nothing; and the lawnmower's plans over the area only.
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "tests/server/label_shots.h"
#include "tests/server/service_fixture.h"
#include "tests/server/team_fixture.h"

namespace oaipp::server {
namespace {

using testing::AddLabelShots;
using testing::CreateWithSpec;
using testing::InProcessService;
using testing::LabelShot;
using testing::SmallSpec;

void AddRing(std::initializer_list<double> xy, v1::Ring* ring) {
  for (const double v : xy) ring->add_xy_m(v);
}

// The small field (20 x 20 cells of 0.75 m from (-7.5, -7.5)) without its
// north-east quarter, and a hole [-6, -3]^2 in the south-west: no cell
// centre lies on a ring.
//
//   7.5 +-------+
//       |       |
//     0 |       +-------+
//       | +-+           |
//       | +-+           |
//  -7.5 +---------------+
//     -7.5      0      7.5
v1::MissionSpec AreaSpec() {
  v1::MissionSpec spec = SmallSpec();
  v1::AreaPolygon& l = *spec.add_search_areas();
  AddRing({-7.5, -7.5, 7.5, -7.5, 7.5, 0, 0, 0, 0, 7.5, -7.5, 7.5}, l.mutable_outer());
  AddRing({-6, -6, -6, -3, -3, -3, -3, -6}, l.add_holes());
  return spec;
}

// The drawing's cells, row-major along y.
std::string ExpectedMask() {
  std::string mask;
  for (int row = 0; row < 20; ++row) {
    for (int col = 0; col < 20; ++col) {
      const double x = -7.5 + 0.75 * (col + 0.5), y = -7.5 + 0.75 * (row + 0.5);
      const bool quarter = x > 0 && y > 0;
      const bool hole = x > -6 && x < -3 && y > -6 && y < -3;
      mask.push_back(!quarter && !hole ? 1 : 0);
    }
  }
  return mask;
}

v1::GetMapResponse MapOf(v1::MissionService::Stub& stub, const std::string& name) {
  grpc::ClientContext context;
  v1::GetMapRequest request;
  request.set_name(name);
  request.set_include_cells(true);
  v1::GetMapResponse map;
  const grpc::Status status = stub.GetMap(&context, request, &map);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return map;
}

v1::MissionSpec SpecOf(v1::MissionService::Stub& stub, const std::string& name) {
  grpc::ClientContext context;
  v1::GetMissionRequest get;
  get.set_name(name);
  v1::Mission mission;
  const grpc::Status status = stub.GetMission(&context, get, &mission);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return mission.spec();
}

// The variances' sum over the cells the mask marks.
double MaskedTrace(const v1::GetMapResponse& map, const std::string& mask) {
  double sum = 0.0;
  for (int i = 0; i < map.variance_size(); ++i) {
    if (mask[static_cast<std::size_t>(i)] != 0) sum += map.variance(i);
  }
  return sum;
}

const LabelShot kShots[] = {{-4, 4, 8, 0.0}, {3, -3, 6, 1.0}, {5, 5, 5, 0.0}};

class SearchAreaServiceTest : public testing::TeamStoreTest {};

TEST_F(SearchAreaServiceTest, TheAreaAndItsCellsSurviveARestart) {
  const std::string expected = ExpectedMask();
  for (const int snapshot_every : {0, 1}) {
    SCOPED_TRACE(snapshot_every == 0 ? "from the log" : "from a snapshot");
    const RegistryLimits limits = FreshStore(snapshot_every);
    std::unique_ptr<MissionStore> store = Open();
    v1::MissionSpec spec_before;
    {
      InProcessService first(limits, 2, 64, store.get());
      ASSERT_TRUE(CreateWithSpec(first.stub(), "a", AreaSpec()).ok());
      AddLabelShots(first.stub(), "missions/a", kShots);
      if (snapshot_every > 0) first.registry().FlushSnapshots();
      const v1::GetMapResponse map = MapOf(first.stub(), "missions/a");
      EXPECT_EQ(map.search_area(), expected);
      EXPECT_NEAR(map.search_area_trace(), MaskedTrace(map, expected), 1e-9 * map.trace());
      EXPECT_LT(map.search_area_trace(), map.trace() - 1.0);  // a quarter and a hole left out
      spec_before = SpecOf(first.stub(), "missions/a");
    }
    ASSERT_EQ(spec_before.search_areas_size(), 1);
    EXPECT_EQ(spec_before.search_areas(0).outer().xy_m_size(), 12);
    EXPECT_EQ(spec_before.search_areas(0).holes_size(), 1);
    InProcessService after(limits, 2, 64, store.get());
    ASSERT_TRUE(after.recovered().ok());
    EXPECT_EQ(*after.recovered(), 1);
    const v1::MissionSpec spec_after = SpecOf(after.stub(), "missions/a");
    ASSERT_EQ(spec_after.search_areas_size(), 1);
    EXPECT_TRUE(std::equal(spec_before.search_areas(0).outer().xy_m().begin(),
                           spec_before.search_areas(0).outer().xy_m().end(),
                           spec_after.search_areas(0).outer().xy_m().begin()));
    EXPECT_EQ(MapOf(after.stub(), "missions/a").search_area(), expected);
  }
  // Without an area: no mask, and the area's trace is the trace.
  InProcessService plain;
  ASSERT_TRUE(CreateWithSpec(plain.stub(), "whole", SmallSpec()).ok());
  const v1::GetMapResponse whole = MapOf(plain.stub(), "missions/whole");
  EXPECT_TRUE(whole.search_area().empty());
  EXPECT_EQ(whole.search_area_trace(), whole.trace());
}

TEST_F(SearchAreaServiceTest, ABadAreaIsRefusedNamingItsRingAndNothingIsStored) {
  struct Bad {
    std::string what;
    void (*edit)(v1::MissionSpec&);
    std::string field;
  };
  const std::vector<Bad> bad = {
      {"a bow-tie outer ring",
       [](v1::MissionSpec& s) {
         s.mutable_search_areas(0)->mutable_outer()->clear_xy_m();
         AddRing({-7, -7, 7, 7, 7, -7, -7, 7}, s.mutable_search_areas(0)->mutable_outer());
       },
       "spec.search_areas[0].outer: "},
      {"a hole in the left-out quarter",
       [](v1::MissionSpec& s) {
         s.mutable_search_areas(0)->mutable_holes(0)->clear_xy_m();
         AddRing({2, 2, 4, 2, 4, 4, 2, 4}, s.mutable_search_areas(0)->mutable_holes(0));
       },
       "spec.search_areas[0].holes[0]: "},
      {"an open ring",
       [](v1::MissionSpec& s) {
         AddRing({1, 1, 2, 2}, s.add_search_areas()->mutable_outer());
       },
       "spec.search_areas[1].outer: "},
      {"geodetic without an origin",
       [](v1::MissionSpec& s) {
         v1::Ring* r = s.add_search_areas()->mutable_outer();
         for (const double v : {47.0, 8.0, 47.001, 8.0, 47.0, 8.001}) r->add_lat_lon_deg(v);
       },
       "spec.search_areas[1].outer.lat_lon_deg: the mission has no geo_origin"},
  };
  std::vector<Refusal> refusals;
  for (const Bad& b : bad) {
    v1::MissionSpec spec = AreaSpec();
    b.edit(spec);
    refusals.push_back({b.what, spec, b.field});
  }
  ExpectRefusedAndNothingStored(refusals);
}

// The lawnmower flies the area's stretches only: over six replans, each
// from where the last one ended, its trajectories (sampled at 10 Hz) stay
// out of the left-out quarter but for the turns' overshoot, and fly both
// the north lane (which holds area only west of x = 0) and the south one
// east of the quarter's corner.
TEST(SearchAreaLawnmowerTest, ThePatternLeavesTheQuarterOutsideTheAreaAlone) {
  InProcessService s;
  v1::MissionSpec spec = AreaSpec();
  spec.clear_obstacles();
  spec.mutable_planner()->set_kind(v1::PLANNER_KIND_LAWNMOWER);
  ASSERT_TRUE(CreateWithSpec(s.stub(), "mow", spec).ok());
  v1::UavState state = spec.start();
  bool north = false, south_east = false;
  for (int replan = 0; replan < 6; ++replan) {
    grpc::ClientContext context;
    v1::PlanPathRequest request;
    request.set_name("missions/mow");
    *request.mutable_state() = state;
    v1::PlanPathResponse plan;
    const grpc::Status status = s.stub().PlanPath(&context, request, &plan);
    ASSERT_TRUE(status.ok()) << status.error_message();
    ASSERT_GT(plan.trajectory().samples_size(), 1);
    for (const v1::TrajectorySample& sample : plan.trajectory().samples()) {
      const double x = sample.position_m().x(), y = sample.position_m().y();
      EXPECT_FALSE(x > 1.0 && y > 1.0) << "replan " << replan << ": (" << x << ", " << y << ")";
      north = north || y > 1.0;
      south_east = south_east || (x > 1.0 && y < -1.0);
    }
    const v1::TrajectorySample& last =
        plan.trajectory().samples(plan.trajectory().samples_size() - 1);
    const double end_s = state.mission_time_s() + plan.trajectory().duration_s();
    state = v1::UavState();
    *state.mutable_position_m() = last.position_m();
    state.set_mission_time_s(end_s);
  }
  EXPECT_TRUE(north);
  EXPECT_TRUE(south_east);
}

}  // namespace
}  // namespace oaipp::server
