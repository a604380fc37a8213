// A home and a reserve through the service (MissionSpec.home;
// docs/method.md §2.7): in seeded random worlds of a concave fence, no-fly
// zones and buildings, missions are flown plan after plan on the real
// mission clock until the server sends the way home. Every plan and every
// way home keeps the body and tracking error (1.5 m) from all of them, by
// this folder's own distances every 0.01 s; every way home starts where its
// plan ends and ends at home at rest; and flying a plan, its way home and
// the landing leaves the reserve, by this file's own arithmetic from the
// budget and the trajectories' durations. Bad homes are refused naming the
// field, and nothing is stored.
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
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
using testing::CreateWithSpec;
using testing::DerivativeAt;
using testing::Flight;
using testing::InProcessService;
using testing::InsideRing;
using testing::PlanFor;
using testing::Point;
using testing::PositionAt;
using testing::RandomFence;
using testing::RingOf;
using testing::ToBox;
using testing::ToZone;

constexpr double kBudget_s = 45.0;
constexpr double kReserve_s = 4.0;
constexpr double kLandingSpeed_m_s = 2.0;
constexpr double kHomeZ_m = 6.0;

double Distance(const Point& a, const Point& b) {
  return std::hypot(a.x - b.x, a.y - b.y, a.z - b.z);
}

// The nearest a trajectory comes to the fence, a zone or a building, every
// 0.01 s.
double ClosestToAnything(const v1::MissionSpec& spec, const v1::Trajectory& trajectory) {
  v1::PlanPathResponse as_path;
  *as_path.mutable_trajectory() = trajectory;
  const Flight flight{.path = as_path};
  const std::vector<testing::XY> fence = RingOf(spec.fence().polygon());
  double best = std::numeric_limits<double>::infinity();
  const double end = trajectory.duration_s();
  for (int i = 0; i * 0.01 <= end + 0.01; ++i) {
    const Point p = PositionAt(flight, std::min(i * 0.01, end));
    best = std::min(best, InsideRing(fence, {p.x, p.y}));
    for (const v1::Obstacle& zone : spec.no_fly_zones()) best = std::min(best, ToZone(zone, p));
    for (const v1::Obstacle& b : spec.obstacles()) best = std::min(best, ToBox(b, p));
  }
  return best;
}

Point EndPoint(const v1::Trajectory& trajectory) {
  v1::PlanPathResponse as_path;
  *as_path.mutable_trajectory() = trajectory;
  return PositionAt(Flight{.path = as_path}, trajectory.duration_s());
}

Point StartPoint(const v1::Trajectory& trajectory) {
  v1::PlanPathResponse as_path;
  *as_path.mutable_trajectory() = trajectory;
  return PositionAt(Flight{.path = as_path}, 0.0);
}

// Two standing boxes (buildings to 12-20 m) none within 4 m of `keep`'s
// points.
void AddRandomBuildings(std::mt19937& rng, const std::vector<Point>& keep, v1::MissionSpec& spec) {
  std::uniform_real_distribution<double> xy(-9.0, 9.0), half(0.8, 2.0), height(12.0, 20.0);
  for (int i = 0; spec.obstacles_size() < 2 && i < 200; ++i) {
    v1::Obstacle b;
    b.set_id(absl::StrCat("b", i));
    const double h = height(rng);
    v1::Box& box = *b.mutable_box();
    box.mutable_centre_m()->set_x(xy(rng));
    box.mutable_centre_m()->set_y(xy(rng));
    box.mutable_centre_m()->set_z(0.5 * h);
    box.mutable_size_m()->set_x(2 * half(rng));
    box.mutable_size_m()->set_y(2 * half(rng));
    box.mutable_size_m()->set_z(h);
    if (std::all_of(keep.begin(), keep.end(), [&](const Point& p) {
          return ToBox(b, p) >= 4.0 && ToBox(b, {p.x, p.y, 0.0}) >= 4.0;
        })) {
      *spec.add_obstacles() = b;
    }
  }
}

TEST(HomeServiceTest, EveryPlanLeavesAWayHomeWithinTheReserveAndTheLastIsIt) {
  InProcessService service(RegistryLimits{.max_missions = 16, .max_cells_per_mission = 1600});
  std::mt19937 rng(7);
  const v1::PlannerKind kinds[] = {v1::PLANNER_KIND_OAIPP, v1::PLANNER_KIND_RANDOM,
                                   v1::PLANNER_KIND_LAWNMOWER};
  const int trials = UnlessSanitized(6);
  int plans = 0, homes = 0, cuts = 0;
  for (int trial = 0; trial < trials; ++trial) {
    std::uniform_real_distribution<double> near(-4.0, 4.0);
    const Point start{near(rng), near(rng), 10};
    const Point home{near(rng), near(rng), kHomeZ_m};
    v1::MissionSpec spec = testing::TeamSpec({});
    spec.clear_obstacles();
    spec.set_preset("");  // the service's defaults: the body's rule, 1.5 m
    spec.clear_min_separation_m();
    *spec.mutable_fence() = RandomFence(rng);
    AddRandomZones(rng, start, spec);
    // Zones over home or its landing column are not this test's subject.
    for (int z = spec.no_fly_zones_size() - 1; z >= 0; --z) {
      if (ToZone(spec.no_fly_zones(z), home) < 4.0 ||
          ToZone(spec.no_fly_zones(z), {home.x, home.y, 0.0}) < 4.0) {
        spec.mutable_no_fly_zones()->DeleteSubrange(z, 1);
      }
    }
    AddRandomBuildings(rng, {start, home}, spec);
    *spec.mutable_start() = At(start, 0);
    spec.set_budget_s(kBudget_s);
    v1::Home& h = *spec.mutable_home();
    h.mutable_position_m()->set_x(home.x);
    h.mutable_position_m()->set_y(home.y);
    h.mutable_position_m()->set_z(home.z);
    h.set_reserve_s(kReserve_s);
    h.set_landing_speed_m_s(kLandingSpeed_m_s);
    spec.mutable_planner()->set_seed(static_cast<std::uint32_t>(trial + 1));
    spec.mutable_planner()->set_kind(kinds[trial % 3]);
    spec.mutable_planner()->set_generations(6);
    const std::string id = absl::StrCat("home-", trial);
    const grpc::Status made = CreateWithSpec(service.stub(), id, spec);
    ASSERT_TRUE(made.ok()) << id << ": " << made.error_message();
    const double landing_s = kHomeZ_m / kLandingSpeed_m_s;
    // Plan after plan, each from where the last ended, on the mission clock.
    Point from = start;
    v1::UavState state = At(start, 0.0);
    double now = 0.0;
    bool went_home = false;
    for (int leg = 0; leg < 40 && !went_home; ++leg) {
      SCOPED_TRACE(absl::StrCat(id, " leg ", leg, " at ", now, " s"));
      v1::PlanPathResponse path;
      const grpc::Status s = PlanFor(service.stub(), id, "", state, absl::StrCat("p", leg), &path);
      ASSERT_TRUE(s.ok()) << s.error_message();
      ++plans;
      const double duration = path.trajectory().duration_s();
      EXPECT_GE(ClosestToAnything(spec, path.trajectory()), 1.5 - 1e-9);
      ASSERT_TRUE(path.has_remaining_after_return_s());
      const double left_now = kBudget_s - now;
      if (path.returning_home()) {
        went_home = true;
        ++homes;
        EXPECT_FALSE(path.has_way_home());
        EXPECT_EQ(path.stats().stop_reason(), "way_home");
        EXPECT_LT(Distance(EndPoint(path.trajectory()), home), 1e-6);
        EXPECT_NEAR(path.remaining_after_return_s(), left_now - duration - landing_s, 1e-6);
        // Every earlier plan ended where this way home fitted: so does it.
        EXPECT_GE(path.remaining_after_return_s(), kReserve_s - 1e-6);
      } else {
        ASSERT_TRUE(path.has_way_home());
        const v1::Trajectory& back = path.way_home();
        EXPECT_GE(ClosestToAnything(spec, back), 1.5 - 1e-9);
        EXPECT_LT(Distance(StartPoint(back), EndPoint(path.trajectory())), 1e-6);
        EXPECT_LT(Distance(EndPoint(back), home), 1e-6);
        const double left = left_now - duration - back.duration_s() - landing_s;
        EXPECT_NEAR(path.remaining_after_return_s(), left, 1e-6);
        EXPECT_GE(left, kReserve_s - 1e-9);
      }
      // The next plan starts where this one ends, moving if it was cut.
      from = EndPoint(path.trajectory());
      state = At(from, now + duration);
      const Point v = DerivativeAt(path.trajectory(), duration, 1);
      const Point a = DerivativeAt(path.trajectory(), duration, 2);
      state.mutable_velocity_m_s()->set_x(v.x);
      state.mutable_velocity_m_s()->set_y(v.y);
      state.mutable_velocity_m_s()->set_z(v.z);
      state.mutable_acceleration_m_s2()->set_x(a.x);
      state.mutable_acceleration_m_s2()->set_y(a.y);
      state.mutable_acceleration_m_s2()->set_z(a.z);
      cuts += path.stats().stop_reason() == "cut_for_home" ? 1 : 0;
      now += duration;
    }
    EXPECT_TRUE(went_home) << id << ": no way home after 40 plans";
  }
  EXPECT_GE(plans, 2 * trials);
  EXPECT_EQ(homes, trials);
  // Plans cut short so that their way home fits: the search went on.
  EXPECT_GE(cuts, 1);
}

TEST(HomeServiceTest, TheHomeComesBackWithItsDefaultsAndFromWgs84) {
  InProcessService s(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600});
  v1::MissionSpec spec = testing::TeamSpec({});
  spec.clear_obstacles();
  spec.set_preset("");
  spec.clear_min_separation_m();
  *spec.mutable_start() = At({-5, -5, 10}, 0);
  v1::GeoPoint& origin = *spec.mutable_geo_origin();
  origin.set_latitude_deg(47.0);
  origin.set_longitude_deg(8.0);
  origin.set_altitude_m(500.0);
  v1::GeoPoint& there = *spec.mutable_home()->mutable_position_geo();
  there.set_latitude_deg(47.0001);
  there.set_longitude_deg(8.0);
  there.set_altitude_m(508.0);
  v1::Mission created;
  const grpc::Status made = CreateWithSpec(s.stub(), "geo", spec, &created);
  ASSERT_TRUE(made.ok()) << made.error_message();
  const v1::Home& back = created.spec().home();
  EXPECT_FALSE(back.has_position_geo());
  EXPECT_NEAR(back.position_m().x(), 0.0, 1e-6);
  EXPECT_NEAR(back.position_m().y(), 11.12, 0.01);  // 0.0001 deg of latitude at 47 deg
  EXPECT_NEAR(back.position_m().z(), 8.0, 0.01);
  EXPECT_EQ(back.reserve_s(), 0.0);
  EXPECT_EQ(back.landing_speed_m_s(), 1.0);
}

class HomeStoreTest : public testing::TeamStoreTest {};

// The home survives a restart (from the log): the spec comes back with it,
// and a plan retried after the restart gets its first answer, way home
// included, bit for bit.
TEST_F(HomeStoreTest, TheHomeAndThePlansWaysHomeSurviveARestart) {
  const RegistryLimits limits = FreshStore(0);
  std::unique_ptr<MissionStore> store = Open();
  v1::MissionSpec spec = testing::TeamSpec({});
  spec.set_preset("");
  spec.clear_min_separation_m();
  *spec.mutable_start() = At({-10, -10, 10}, 0);
  spec.set_budget_s(40);
  *spec.mutable_home()->mutable_position_m() = At({10, 10, 6}, 0).position_m();
  spec.mutable_home()->set_reserve_s(5);
  spec.mutable_planner()->set_kind(v1::PLANNER_KIND_RANDOM);
  v1::PlanPathResponse first, again;
  {
    InProcessService before(limits, 2, 64, store.get());
    ASSERT_TRUE(CreateWithSpec(before.stub(), "h", spec).ok());
    ASSERT_TRUE(PlanFor(before.stub(), "h", "", At({-10, -10, 10}, 0), "p1", &first).ok());
    ASSERT_TRUE(first.has_way_home());
  }
  InProcessService after(limits, 2, 64, store.get());
  ASSERT_TRUE(after.recovered().ok());
  EXPECT_EQ(*after.recovered(), 1);
  grpc::ClientContext context;
  v1::GetMissionRequest get;
  get.set_name("missions/h");
  v1::Mission mission;
  ASSERT_TRUE(after.stub().GetMission(&context, get, &mission).ok());
  EXPECT_EQ(mission.spec().home().position_m().x(), 10.0);
  EXPECT_EQ(mission.spec().home().reserve_s(), 5.0);
  ASSERT_TRUE(PlanFor(after.stub(), "h", "", At({-10, -10, 10}, 0), "p1", &again).ok());
  EXPECT_EQ(again.SerializeAsString(), first.SerializeAsString());
}

TEST_F(HomeStoreTest, BadHomesAreRefusedNamingTheField) {
  v1::MissionSpec base = testing::TeamSpec({});
  base.clear_obstacles();
  base.set_preset("");
  base.clear_min_separation_m();
  *base.mutable_start() = At({-10, -10, 10}, 0);
  base.set_budget_s(60);
  const auto with_home = [&](double x, double y, double z) {
    v1::MissionSpec spec = base;
    spec.mutable_home()->mutable_position_m()->set_x(x);
    spec.mutable_home()->mutable_position_m()->set_y(y);
    spec.mutable_home()->mutable_position_m()->set_z(z);
    return spec;
  };
  const auto box = [](v1::MissionSpec& spec, const std::string& id, double cx, double cy, double sx,
                      double sy, double top) {
    v1::Obstacle& b = *spec.add_obstacles();
    b.set_id(id);
    b.mutable_box()->mutable_centre_m()->set_x(cx);
    b.mutable_box()->mutable_centre_m()->set_y(cy);
    b.mutable_box()->mutable_centre_m()->set_z(0.5 * top);
    b.mutable_box()->mutable_size_m()->set_x(sx);
    b.mutable_box()->mutable_size_m()->set_y(sy);
    b.mutable_box()->mutable_size_m()->set_z(top);
  };
  std::vector<Refusal> refusals;
  {
    v1::MissionSpec spec = with_home(5, 5, 10);
    box(spec, "house", 5, 5, 4, 4, 12);
    refusals.push_back({"a home inside a building", spec,
                        "spec.home.position_m: (5, 5, 10) is "
                        "inside an obstacle"});
  }
  {
    // 1.2 m beside the column down from home, 4 m below it.
    v1::MissionSpec spec = with_home(5, 5, 10);
    box(spec, "shed", 5, 7.2, 2, 2, 6);
    refusals.push_back({"a landing past a shed", spec, "spec.home.position_m: the landing"});
  }
  {
    // A courtyard closed on all four sides up past the flight volume's top.
    v1::MissionSpec spec = with_home(5, 5, 10);
    box(spec, "n", 5, 9, 10, 2, 40);
    box(spec, "s", 5, 1, 10, 2, 40);
    box(spec, "e", 9, 5, 2, 10, 40);
    box(spec, "w", 1, 5, 2, 10, 40);
    refusals.push_back(
        {"a home no way leads to", spec, "spec.home.position_m: unreachable from spec.start"});
  }
  refusals.push_back({"a home above the flight volume", with_home(0, 0, 40),
                      "spec.home.position_m: (0, 0, 40) lies outside the flight volume"});
  {
    v1::MissionSpec spec = with_home(0, 0, 10);
    spec.mutable_home()->clear_position_m();
    refusals.push_back({"a home with no position", spec, "spec.home.position_m: required"});
  }
  {
    v1::MissionSpec spec = with_home(0, 0, 10);
    spec.mutable_home()->set_reserve_s(60);
    refusals.push_back({"a reserve of the whole budget", spec, "spec.home.reserve_s"});
  }
  {
    v1::MissionSpec spec = with_home(0, 0, 10);
    spec.mutable_home()->set_reserve_s(-1);
    refusals.push_back({"a negative reserve", spec, "spec.home.reserve_s"});
  }
  {
    v1::MissionSpec spec = with_home(0, 0, 10);
    spec.mutable_home()->set_landing_speed_m_s(0);
    refusals.push_back({"a landing speed of 0", spec, "spec.home.landing_speed_m_s"});
  }
  {
    v1::MissionSpec spec = with_home(0, 0, 10);
    spec.mutable_home()->clear_position_m();
    spec.mutable_home()->mutable_position_geo()->set_latitude_deg(47);
    refusals.push_back({"a geodetic home without geo_origin", spec, "spec.home.position_geo"});
  }
  {
    v1::MissionSpec spec = testing::TeamSpec({{-10, -10, 10}, {10, 10, 10}});
    spec.clear_obstacles();
    *spec.mutable_home()->mutable_position_m() = At({0, 0, 10}, 0).position_m();
    refusals.push_back({"a home with a team", spec, "spec.home: not available with a team"});
  }
  ExpectRefusedAndNothingStored(refusals);
}

}  // namespace
}  // namespace oaipp::server
