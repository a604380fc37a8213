// Every RPC through an in-process channel: success and each error code.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

#include "absl/strings/escaping.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/synchronization/mutex.h"
#include "absl/synchronization/notification.h"
#include "api/geometry.h"
#include "api/measurement.h"
#include "api/metadata.h"
#include "api/spec.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "server/mission.h"
#include "tests/server/service_fixture.h"

namespace oaipp::server {
namespace {

using testing::CreateEndless;
using testing::CreateSmall;
using testing::Eventually;
using ::testing::HasSubstr;
using testing::InProcessService;
using testing::LabelMeasurement;
using testing::PlanFromCorner;
using testing::SmallSpec;

TEST(ServiceTest, CreateGetListDelete) {
  InProcessService s;
  const v1::Mission created = CreateSmall(s.stub(), "alpha");
  EXPECT_EQ(created.name(), "missions/alpha");
  EXPECT_EQ(created.obstacles_size(), 1);
  // The effective spec has every default filled in.
  EXPECT_TRUE(created.spec().sensor().has_rate_hz());
  EXPECT_DOUBLE_EQ(created.spec().sensor().rate_hz(), 0.15);
  EXPECT_GT(created.trace(), 0.0);
  EXPECT_GT(created.map_bytes(), 8 * 400 * 400);

  grpc::ClientContext get_context;
  v1::GetMissionRequest get;
  get.set_name("missions/alpha");
  v1::Mission got;
  ASSERT_TRUE(s.stub().GetMission(&get_context, get, &got).ok());
  EXPECT_EQ(got.spec().SerializeAsString(), created.spec().SerializeAsString());

  CreateSmall(s.stub(), "beta");
  CreateSmall(s.stub(), "gamma");
  std::vector<std::string> names;
  std::string token;
  do {
    grpc::ClientContext context;
    v1::ListMissionsRequest list;
    list.set_page_size(2);
    list.set_page_token(token);
    v1::ListMissionsResponse page;
    ASSERT_TRUE(s.stub().ListMissions(&context, list, &page).ok());
    for (const auto& m : page.missions()) names.push_back(m.name());
    token = page.next_page_token();
  } while (!token.empty());
  EXPECT_EQ(names, (std::vector<std::string>{"missions/alpha", "missions/beta", "missions/gamma"}));

  grpc::ClientContext delete_context;
  v1::DeleteMissionRequest del;
  del.set_name("missions/beta");
  v1::DeleteMissionResponse deleted;
  ASSERT_TRUE(s.stub().DeleteMission(&delete_context, del, &deleted).ok());
  grpc::ClientContext again;
  v1::GetMissionRequest gone;
  gone.set_name("missions/beta");
  EXPECT_EQ(s.stub().GetMission(&again, gone, &got).error_code(), grpc::StatusCode::NOT_FOUND);
}

// Missions over the same obstacles share one ESDF: each counts half of it
// while two hold it, and a mission whose obstacles change gets its own again
// without changing the other's (alpha counts its grid whole again).
TEST(ServiceTest, MissionsOverTheSameObstaclesShareOneEsdf) {
  InProcessService s;
  const std::int64_t map = 8 * 400 * 401;  // mean and covariance of 20 x 20 cells
  const std::int64_t alone = CreateSmall(s.stub(), "alpha").map_bytes();
  const std::int64_t esdf = alone - map;
  ASSERT_GT(esdf, 100'000);
  EXPECT_EQ(CreateSmall(s.stub(), "beta").map_bytes(), map + esdf / 2);
  const auto bytes = [&](const std::string& id) {
    grpc::ClientContext context;
    v1::GetMissionRequest get;
    get.set_name("missions/" + id);
    v1::Mission got;
    EXPECT_TRUE(s.stub().GetMission(&context, get, &got).ok());
    return got.map_bytes();
  };
  EXPECT_EQ(bytes("alpha"), map + esdf / 2);

  v1::UpdateObstaclesRequest update;
  update.set_name("missions/beta");
  v1::Obstacle* added = update.add_add();
  added->set_id("b2");
  added->mutable_box()->mutable_centre_m()->set_x(4);
  added->mutable_box()->mutable_centre_m()->set_y(-4);
  added->mutable_box()->mutable_centre_m()->set_z(5);
  *added->mutable_box()->mutable_size_m() = api::ToProto(Vec3(1, 1, 10));
  {
    grpc::ClientContext context;
    v1::UpdateObstaclesResponse updated;
    ASSERT_TRUE(s.stub().UpdateObstacles(&context, update, &updated).ok());
  }
  EXPECT_EQ(bytes("alpha"), alone);
  // Beta's grid is its own now, and holds the blocks around b2 as well.
  EXPECT_GT(bytes("beta"), alone);
}

// Page tokens are opaque and stable: deleting missions between pages
// neither hides nor repeats one, and a token made up by the client (the old
// raw offsets, a well-formed position with a made-up signature) or made by
// another server (another key) is refused naming page_token.
TEST(ServiceTest, PagesStayRightWhenMissionsAreDeletedBetweenThem) {
  InProcessService s;
  for (const char* id : {"m0", "m1", "m2", "m3", "m4"}) CreateSmall(s.stub(), id);
  const auto list = [&](const std::string& token, v1::ListMissionsResponse* page) {
    grpc::ClientContext context;
    v1::ListMissionsRequest request;
    request.set_page_size(2);
    request.set_page_token(token);
    return s.stub().ListMissions(&context, request, page);
  };
  v1::ListMissionsResponse first;
  ASSERT_TRUE(list("", &first).ok());
  ASSERT_EQ(first.missions_size(), 2);
  EXPECT_EQ(first.missions(1).name(), "missions/m1");
  for (const char* gone : {"missions/m1", "missions/m2"}) {
    grpc::ClientContext context;
    v1::DeleteMissionRequest del;
    del.set_name(gone);
    v1::DeleteMissionResponse deleted;
    ASSERT_TRUE(s.stub().DeleteMission(&context, del, &deleted).ok());
  }
  v1::ListMissionsResponse second;
  ASSERT_TRUE(list(first.next_page_token(), &second).ok());
  ASSERT_EQ(second.missions_size(), 2);  // with offsets, m3 was skipped
  EXPECT_EQ(second.missions(0).name(), "missions/m3");
  EXPECT_EQ(second.missions(1).name(), "missions/m4");
  EXPECT_TRUE(second.next_page_token().empty());
  InProcessService other;
  for (const char* id : {"m0", "m1", "m2"}) CreateSmall(other.stub(), id);
  v1::ListMissionsResponse others_page;
  {
    grpc::ClientContext context;
    v1::ListMissionsRequest request;
    request.set_page_size(2);
    ASSERT_TRUE(other.stub().ListMissions(&context, request, &others_page).ok());
    ASSERT_FALSE(others_page.next_page_token().empty());
  }
  for (const std::string& forged :
       std::vector<std::string>{"2", "cDEuMg", first.next_page_token() + "x",
                                absl::WebSafeBase64Escape("n.2.00000000000000000000000000000000"),
                                others_page.next_page_token()}) {
    v1::ListMissionsResponse page;
    const grpc::Status status = list(forged, &page);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << forged;
    EXPECT_NE(status.error_message().find("page_token"), std::string::npos);
  }
}

// Missions over the same kind of field share one prior computation, and
// start from the map a mission built on its own would have.
TEST(ServiceTest, MissionsOfOneFieldShapeShareThePrior) {
  InProcessService s;
  const v1::Mission a = CreateSmall(s.stub(), "a");
  const v1::Mission b = CreateSmall(s.stub(), "b");
  EXPECT_EQ(s.registry().site_caches().PriorComputations(), 1);
  auto config = api::MissionSpecToConfig(SmallSpec());
  ASSERT_TRUE(config.ok()) << config.status();
  auto alone = Mission::Create("alone", *config);
  ASSERT_TRUE(alone.ok()) << alone.status();
  EXPECT_EQ(a.trace(), (*alone)->Snapshot().trace);
  EXPECT_EQ(b.trace(), a.trace());
  // A finer grid is another prior.
  grpc::ClientContext context;
  v1::CreateMissionRequest request;
  *request.mutable_spec() = SmallSpec();
  request.mutable_spec()->mutable_field()->set_resolution_m(0.5);
  v1::Mission fine;
  ASSERT_TRUE(s.stub().CreateMission(&context, request, &fine).ok());
  EXPECT_EQ(s.registry().site_caches().PriorComputations(), 2);
  EXPECT_NE(fine.trace(), a.trace());
  // Without a cache every mission computes its own, to the same map.
  InProcessService uncached({.max_missions = 4, .max_cells_per_mission = 1600, .prior_cache = 0});
  EXPECT_EQ(CreateSmall(uncached.stub(), "c").trace(), a.trace());
  EXPECT_EQ(uncached.registry().site_caches().PriorComputations(), 0);
}

// Two missions "a" and "b" over one site sharing its starting map, and
// "alone" over the same site with nothing shared.
struct SharedSite {
  absl::StatusOr<MissionConfig> config = api::MissionSpecToConfig(SmallSpec());
  StartMapCache start_maps{/*capacity=*/4};
  absl::StatusOr<std::shared_ptr<Mission>> a, b, alone;
  void Create() {
    ASSERT_TRUE(config.ok()) << config.status();
    const SiteCaches caches{.start_maps = &start_maps};
    a = Mission::Create("a", *config, caches);
    b = Mission::Create("b", *config, caches);
    alone = Mission::Create("alone", *config);
    ASSERT_TRUE(a.ok() && b.ok() && alone.ok());
  }
};

// Missions over one site copy one starting map (the prior with the ground
// under its building fused) instead of fusing it again, and the copy is the
// map a mission fusing on its own gets, bit for bit. Another site, or other
// GP parameters, is another starting map.
TEST(ServiceTest, MissionsOverOneSiteShareTheirStartingMap) {
  SharedSite site;
  ASSERT_NO_FATAL_FAILURE(site.Create());
  const auto& config = site.config;
  StartMapCache& start_maps = site.start_maps;
  auto &a = site.a, &b = site.b, &alone = site.alone;
  EXPECT_EQ(start_maps.computations(), 1);
  const MissionState own = (*alone)->CaptureState();
  // The building's footprint (2 x 4 m over 0.75 m cells) was fused.
  ASSERT_GE(own.covered_cells.size(), 8u);
  for (const auto* m : {&*a, &*b}) {
    const MissionState copied = (*m)->CaptureState();
    EXPECT_TRUE(copied.mean == own.mean);
    EXPECT_TRUE(copied.covariance == own.covariance);
    EXPECT_EQ(copied.covered_cells, own.covered_cells);
  }
  // A fused cell is near certain: its variance is below kNearCertainVariance
  // while a free cell keeps a prior variance of about 0.2 or more.
  const int covered = own.covered_cells.front();
  EXPECT_LT(own.covariance(covered, covered), GpMap::kNearCertainVariance);
  // A measurement changes only the mission it is for: the map it shared is
  // copied first.
  auto measurement = api::MeasurementFromProto(LabelMeasurement("missions/a", 3, 3, 10, 1.0, 1.0));
  ASSERT_TRUE(measurement.ok()) << measurement.status();
  ASSERT_TRUE((*a)->AddMeasurement(*measurement, "").ok());
  EXPECT_LT((*a)->CaptureState().covariance.trace(), own.covariance.trace() - 1.0);
  EXPECT_TRUE((*b)->CaptureState().covariance == own.covariance);
  const SiteCaches caches{.start_maps = &start_maps};
  auto later = Mission::Create("c", *config, caches);
  ASSERT_TRUE(later.ok());
  EXPECT_TRUE((*later)->CaptureState().covariance == own.covariance);
  const MissionConfig other_gp = [&] {
    MissionConfig c = *config;
    c.gp.prior_mean = 0.2;
    return c;
  }();
  const MissionConfig other_site = [&] {
    MissionConfig c = *config;
    std::get<Box>(c.obstacles.front().shape).centre_W.x() += 3.0;
    return c;
  }();
  ASSERT_TRUE(Mission::Create("e", other_gp, caches).ok());
  ASSERT_TRUE(Mission::Create("f", other_site, caches).ok());
  EXPECT_EQ(start_maps.computations(), 3);
}

// The first plans of missions that still hold one shared starting map, from
// one start point, condition that map on the first shot once, and plan
// exactly what a mission on its own plans. A mission whose map has changed
// conditions its own.
TEST(ServiceTest, FirstPlansOverASharedStartingMapConditionItOnce) {
  SharedSite site;
  ASSERT_NO_FATAL_FAILURE(site.Create());
  const auto& config = site.config;
  StartMapCache& start_maps = site.start_maps;
  auto &a = site.a, &b = site.b, &alone = site.alone;
  auto conditionings = [&] {
    std::int64_t n = -1;
    EXPECT_TRUE(start_maps.AnyHeld([&](const StartMap& held) {
      n = held.conditioned->computations();
      return true;
    }));
    return n;
  };
  const UavState start = config->start;
  auto own = (*alone)->Plan(start, std::nullopt, "p0", {});
  ASSERT_TRUE(own.ok()) << own.status();
  ASSERT_GT(own->measurement_poses.size(), 0u);
  ASSERT_NEAR(own->measurement_poses.front().mission_time_s, start.mission_time_s, 1e-9)
      << "the first shot is due at the start: the plan conditions on it";
  for (const auto* m : {&*a, &*b}) {
    auto shared = (*m)->Plan(start, std::nullopt, "p0", {});
    ASSERT_TRUE(shared.ok()) << shared.status();
    EXPECT_EQ(shared->control_waypoints_W, own->control_waypoints_W);
    EXPECT_EQ(shared->objective, own->objective);
  }
  EXPECT_EQ(conditionings(), 1);
  // After a measurement `a` plans over its own copy: nothing more is shared.
  auto measurement = api::MeasurementFromProto(LabelMeasurement("missions/a", 3, 3, 10, 1.0, 1.0));
  ASSERT_TRUE(measurement.ok()) << measurement.status();
  ASSERT_TRUE((*a)->AddMeasurement(*measurement, "").ok());
  ASSERT_TRUE((*alone)->AddMeasurement(*measurement, "").ok());
  // At the next shot's time and the same place: the start shot's key is the
  // first plans', so a plan that still used the shared conditioning would
  // plan over the map without the measurement.
  UavState later = start;
  later.mission_time_s = 1.0 / config->sensor_rate_hz();
  auto changed = (*a)->Plan(later, std::nullopt, "p1", {});
  auto changed_alone = (*alone)->Plan(later, std::nullopt, "p1", {});
  ASSERT_TRUE(changed.ok() && changed_alone.ok());
  ASSERT_NEAR(changed->measurement_poses.front().mission_time_s, later.mission_time_s, 1e-9);
  EXPECT_EQ(changed->control_waypoints_W, changed_alone->control_waypoints_W);
  EXPECT_EQ(changed->objective, changed_alone->objective);
  EXPECT_NE(changed->objective, own->objective);
  EXPECT_EQ(conditionings(), 1);
}

TEST(ServiceTest, MeasurementsShrinkTheMapAndRequestIdsFuseOnce) {
  InProcessService s;
  CreateSmall(s.stub(), "m");
  const v1::AddMeasurementRequest request = LabelMeasurement("missions/m", 3, 3, 10, 1.0, 1.0);
  v1::AddMeasurementRequest with_id = request;
  with_id.set_request_id("shot-1");
  v1::AddMeasurementResponse first, second;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(s.stub().AddMeasurement(&context, with_id, &first).ok());
  }
  {
    grpc::ClientContext context;  // a retry of the same call
    ASSERT_TRUE(s.stub().AddMeasurement(&context, with_id, &second).ok());
  }
  EXPECT_EQ(first.measurements_fused(), 1);
  EXPECT_EQ(second.measurements_fused(), 1);
  EXPECT_EQ(first.trace(), second.trace());
  EXPECT_EQ(first.cells_fused(), 9);
  grpc::ClientContext context;
  v1::GetMissionRequest get;
  get.set_name("missions/m");
  v1::Mission m;
  ASSERT_TRUE(s.stub().GetMission(&context, get, &m).ok());
  EXPECT_EQ(m.measurements_fused(), 1);
  EXPECT_DOUBLE_EQ(m.trace(), first.trace());
}

TEST(ServiceTest, DetectionsAreProjectedToCells) {
  InProcessService s;
  CreateSmall(s.stub(), "d");
  v1::AddMeasurementRequest request;
  request.set_name("missions/d");
  request.set_mission_time_s(2.0);
  request.mutable_camera_position_m()->set_x(4);
  request.mutable_camera_position_m()->set_y(3);
  request.mutable_camera_position_m()->set_z(10);
  testing::AddPersonUnderCamera(request);
  v1::AddMeasurementResponse response;
  grpc::ClientContext context;
  const grpc::Status status = s.stub().AddMeasurement(&context, request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_GT(response.cells_fused(), 50);  // the whole visible image footprint is labelled

  grpc::ClientContext map_context;
  v1::GetMapRequest get;
  get.set_name("missions/d");
  get.set_include_cells(true);
  v1::GetMapResponse map;
  ASSERT_TRUE(s.stub().GetMap(&map_context, get, &map).ok());
  // The cell under the camera (4, 3) holds a target now; a far corner no more
  // than the prior.
  const int col = static_cast<int>((4 + 7.5) / 0.75), row = static_cast<int>((3 + 7.5) / 0.75);
  EXPECT_GT(map.mean(row * 20 + col), 0.5);
  EXPECT_LE(map.mean(2 * 20 + 2), 0.1 + 1e-9);
}

TEST(ServiceTest, PlanPathReturnsASafeTrajectoryAndObstaclesMatter) {
  InProcessService s;
  CreateSmall(s.stub(), "p");
  v1::PlanPathRequest request;
  request.set_name("missions/p");
  request.mutable_state()->mutable_position_m()->set_x(-4);
  request.mutable_state()->mutable_position_m()->set_y(4);
  request.mutable_state()->mutable_position_m()->set_z(8);
  v1::PlanPathResponse path;
  {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    const grpc::Status status = s.stub().PlanPath(&context, request, &path);
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  EXPECT_TRUE(path.collision_free());
  EXPECT_GT(path.trajectory().duration_s(), 0.0);
  ASSERT_GT(path.trajectory().samples_size(), 1);
  EXPECT_NEAR(path.trajectory().samples(0).position_m().x(), -4, 1e-9);
  EXPECT_EQ(path.control_waypoints_m_size(), 3);
  EXPECT_GT(path.stats().evaluations(), 0);

  // Moving the building onto the start makes the start invalid.
  v1::UpdateObstaclesRequest update;
  update.set_name("missions/p");
  v1::Obstacle* moved = update.add_replace();
  moved->set_id("b1");
  moved->mutable_cylinder()->mutable_centre_m()->set_x(-4);
  moved->mutable_cylinder()->mutable_centre_m()->set_y(4);
  moved->mutable_cylinder()->mutable_centre_m()->set_z(10);
  moved->mutable_cylinder()->set_radius_m(1);
  moved->mutable_cylinder()->set_height_m(20);
  v1::UpdateObstaclesResponse updated;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(s.stub().UpdateObstacles(&context, update, &updated).ok());
  }
  EXPECT_EQ(updated.obstacle_count(), 1);
  EXPECT_GT(updated.esdf_voxels_recomputed(), 0);
  grpc::ClientContext context;
  const grpc::Status blocked = s.stub().PlanPath(&context, request, &path);
  EXPECT_EQ(blocked.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(blocked.error_message(), HasSubstr("inside an obstacle"));
}

// From a moving start PlanPath answers where the UAV can stop, and where it
// cannot, names the face or the obstacle in the API's words.
TEST(ServiceTest, PlanPathFromAMovingStartNamesWhyItCannotStop) {
  InProcessService s;
  CreateSmall(s.stub(), "moving");
  auto plan = [&](Vec3 p, Vec3 v, v1::PlanPathResponse* path) {
    v1::PlanPathRequest request;
    request.set_name("missions/moving");
    *request.mutable_state()->mutable_position_m() = api::ToProto(p);
    *request.mutable_state()->mutable_velocity_m_s() = api::ToProto(v);
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
    return s.stub().PlanPath(&context, request, path);
  };
  v1::PlanPathResponse path;
  // 3.5 m/s east, 1 m from the east face at 7.5 m: stopping takes 2.04 m.
  grpc::Status status = plan({6.5, 4, 8}, {3.5, 0, 0}, &path);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(status.error_message(), HasSubstr("state.velocity_m_s: stopping from 3.50 m/s"));
  EXPECT_THAT(status.error_message(), HasSubstr("spec.flight.max_accel_m_s2 = 3 takes 2.04 m"));
  EXPECT_THAT(status.error_message(), HasSubstr("x max face at 7.5 m"));
  // 4 m/s at the building b1 (its west face at x = -1), 2 m away.
  status = plan({-3, -2, 8}, {4, 0, 0}, &path);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(status.error_message(), HasSubstr("obstacle 'b1'"));
  // 3 m/s east with 3.5 m of room: a safe path that starts at that velocity.
  status = plan({4, 4, 8}, {3, 0, 0}, &path);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_TRUE(path.collision_free());
  ASSERT_GT(path.trajectory().samples_size(), 1);
  EXPECT_NEAR(path.trajectory().samples(0).velocity_m_s().x(), 3, 1e-6);
  EXPECT_GE(path.stats().stop_first_s(), 0.0);
}

// A planning budget that ends before any safe path is found is not the
// call's deadline: FAILED_PRECONDITION naming planning_budget_s. (The random
// planner gives up at once when its deadline has passed.)
TEST(ServiceTest, APlanningBudgetThatEndsWithoutAPathIsNotADeadline) {
  InProcessService s;
  grpc::ClientContext create_context;
  v1::CreateMissionRequest create;
  create.set_mission_id("random");
  *create.mutable_spec() = SmallSpec();
  create.mutable_spec()->mutable_planner()->set_kind(v1::PLANNER_KIND_RANDOM);
  v1::Mission mission;
  ASSERT_TRUE(s.stub().CreateMission(&create_context, create, &mission).ok());
  v1::PlanPathRequest request;
  request.set_name("missions/random");
  *request.mutable_state()->mutable_position_m() = api::ToProto(Vec3(-4, 4, 8));
  request.set_planning_budget_s(1e-9);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  v1::PlanPathResponse path;
  const grpc::Status status = s.stub().PlanPath(&context, request, &path);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << status.error_message();
  EXPECT_THAT(status.error_message(), HasSubstr("planning_budget_s: no collision-free path"));
}

// Creates `n` missions "<prefix>0", "<prefix>1", ... with `generations`
// CMA-ES generations, holds the only planner until a plan for each waits,
// then lets them run: their answers, in mission order.
void PlanQueuedTogether(InProcessService& s, const std::string& prefix, int n, int generations,
                        std::vector<grpc::Status>* statuses,
                        std::vector<v1::PlanPathResponse>* paths,
                        std::vector<int>* answer_order = nullptr) {
  for (int i = 0; i < n; ++i) {
    grpc::ClientContext context;
    v1::CreateMissionRequest create;
    create.set_mission_id(absl::StrCat(prefix, i));
    *create.mutable_spec() = SmallSpec();
    create.mutable_spec()->mutable_planner()->set_generations(generations);
    v1::Mission mission;
    ASSERT_TRUE(s.stub().CreateMission(&context, create, &mission).ok());
  }
  absl::Notification release;
  ASSERT_TRUE(s.planners().Submit("blocker", [&] { release.WaitForNotification(); }).ok());
  statuses->assign(n, grpc::Status());
  paths->assign(n, v1::PlanPathResponse());
  absl::Mutex order_mu;
  std::vector<int> order;
  std::vector<std::thread> callers;
  for (int i = 0; i < n; ++i) {
    callers.emplace_back([&, i] {
      v1::PlanPathRequest request;
      request.set_name(absl::StrCat("missions/", prefix, i));
      *request.mutable_state()->mutable_position_m() = api::ToProto(Vec3(-4, 4, 8));
      grpc::ClientContext context;
      context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
      (*statuses)[i] = s.stub().PlanPath(&context, request, &(*paths)[i]);
      absl::MutexLock lock(&order_mu);
      order.push_back(i);
    });
  }
  const bool all_wait = Eventually([&] { return s.planners().waiting() == n; });
  release.Notify();
  for (auto& c : callers) c.join();
  if (answer_order != nullptr) *answer_order = order;
  ASSERT_TRUE(all_wait);
}

// Overload: with shed_above = 1 and one planning thread, a plan that starts
// while k > 1 others wait runs 1/k of its CMA-ES generations and says so.
TEST(ServiceTest, PlansThatStartBehindAQueueRunAShareOfTheirSearch) {
  InProcessService s({.max_missions = 8, .max_cells_per_mission = 1600}, /*planning_threads=*/1,
                     /*planning_queue=*/8, nullptr, nullptr, {.shed_above = 1.0});
  constexpr int kPlans = 4;
  constexpr int kGenerations = 20;
  std::vector<grpc::Status> statuses;
  std::vector<v1::PlanPathResponse> paths;
  ASSERT_NO_FATAL_FAILURE(PlanQueuedTogether(s, "m", kPlans, kGenerations, &statuses, &paths));
  // They start with 3, 2, 1 and 0 others waiting: shares 1/3, 1/2, 1, 1.
  std::vector<double> fractions;
  for (int i = 0; i < kPlans; ++i) {
    ASSERT_TRUE(statuses[i].ok()) << statuses[i].error_message();
    const v1::PlannerStats& stats = paths[i].stats();
    fractions.push_back(stats.search_fraction());
    EXPECT_EQ(stats.generations(),
              static_cast<int>(std::ceil(kGenerations * stats.search_fraction() - 1e-9)));
  }
  std::sort(fractions.begin(), fractions.end());
  EXPECT_THAT(fractions,
              ::testing::ElementsAre(::testing::DoubleEq(1.0 / 3), ::testing::DoubleEq(0.5),
                                     ::testing::DoubleEq(1.0), ::testing::DoubleEq(1.0)));
}

// Overload: with a plan latency bound, a plan that waited longer than the
// bound for a planner plans only a hundredth of the bound and answers with its
// best path by then, saying so (stop_reason "deadline", queued_s beyond
// the bound).
TEST(ServiceTest, PlansThatWaitedPastTheLatencyBoundAnswerWithTheirGreedyStart) {
  // A hundredth of the bound is far less than the whole search takes (50 000
  // generations), and the plan waits longer than the bound.
  constexpr absl::Duration kBound = absl::Seconds(1);
  constexpr absl::Duration kHeld = absl::Milliseconds(1500);
  ManualClock clock;
  InProcessService s({.max_missions = 8, .max_cells_per_mission = 1600}, /*planning_threads=*/1,
                     /*planning_queue=*/8, nullptr, nullptr,
                     {.plan_latency = kBound, .clock = &clock});
  for (const char* id : {"late", "free"}) {
    grpc::ClientContext context;
    v1::CreateMissionRequest create;
    create.set_mission_id(id);
    *create.mutable_spec() = SmallSpec();
    create.mutable_spec()->mutable_planner()->set_generations(50000);
    v1::Mission mission;
    ASSERT_TRUE(s.stub().CreateMission(&context, create, &mission).ok());
  }
  auto plan = [&](const std::string& id, v1::PlanPathResponse* path) {
    v1::PlanPathRequest request;
    request.set_name("missions/" + id);
    *request.mutable_state()->mutable_position_m() = api::ToProto(Vec3(-4, 4, 8));
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
    return s.stub().PlanPath(&context, request, path);
  };
  absl::Notification release;
  ASSERT_TRUE(s.planners().Submit("blocker", [&] { release.WaitForNotification(); }).ok());
  v1::PlanPathResponse late;
  grpc::Status late_status;
  std::thread caller([&] { late_status = plan("late", &late); });
  // The blocker runs and the late plan waits behind it.
  ASSERT_TRUE(
      Eventually([&] { return s.planners().running() == 1 && s.planners().waiting() == 1; }));
  clock.Advance(kHeld);
  release.Notify();
  caller.join();
  ASSERT_TRUE(late_status.ok()) << late_status.error_message();
  EXPECT_EQ(late.stats().stop_reason(), "deadline");
  EXPECT_LT(late.stats().generations(), 50000);
  // It waited past the bound: held 1.5 s on the service's clock.
  EXPECT_DOUBLE_EQ(late.stats().queued_s(), absl::ToDoubleSeconds(kHeld));
  EXPECT_TRUE(late.collision_free());
  EXPECT_GT(late.trajectory().segments_size(), 0);

  // Nothing queued: the whole bound is the plan's, and its search ends there
  // too.
  v1::PlanPathResponse free;
  const grpc::Status free_status = plan("free", &free);
  ASSERT_TRUE(free_status.ok()) << free_status.error_message();
  EXPECT_EQ(free.stats().stop_reason(), "deadline");
  EXPECT_LT(free.stats().queued_s(), late.stats().queued_s());
  EXPECT_TRUE(free.collision_free());
}

// Take-off pacing, with `max_take_off_plans` = 1 and one planning thread.
struct PacingAnswer {
  grpc::Status status;
  std::optional<std::int64_t> retry_after_ms;
  bool retry_header = false;  // the header was sent at all
};

PacingAnswer PlanAt(InProcessService& s, const std::string& id, double mission_time_s, double vx,
                    double budget_s = 0.0) {
  v1::PlanPathRequest request;
  request.set_name("missions/" + id);
  *request.mutable_state()->mutable_position_m() = api::ToProto(Vec3(-4, 4, 8));
  request.mutable_state()->mutable_velocity_m_s()->set_x(vx);
  request.mutable_state()->set_mission_time_s(mission_time_s);
  if (budget_s > 0.0) request.set_planning_budget_s(budget_s);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  v1::PlanPathResponse path;
  const grpc::Status status = s.stub().PlanPath(&context, request, &path);
  return {status, api::RetryAfterMs(context),
          context.GetServerTrailingMetadata().count(api::kRetryAfterHeader) > 0};
}

void ExpectPaced(const PacingAnswer& refused) {
  EXPECT_EQ(refused.status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(refused.status.error_message(), HasSubstr("take-off"));
  ASSERT_TRUE(refused.retry_after_ms.has_value());
  EXPECT_GE(*refused.retry_after_ms, 1);
}

// With one take-off plan queued (two planning threads held, so the queue is
// short), the next UAV at rest at mission time 0 is refused at once with a
// retry delay; a moving start is not paced, and once the take-off plan has
// ended the next one is admitted.
TEST(ServiceTest, TakeOffPlansBeyondTheLimitAreRefusedWithARetryDelay) {
  InProcessService s({.max_missions = 8, .max_cells_per_mission = 1600}, /*planning_threads=*/2,
                     /*planning_queue=*/8, nullptr, nullptr, {.max_take_off_plans = 1});
  for (const char* id : {"a", "b", "c"}) CreateSmall(s.stub(), id);
  absl::Notification release;
  for (const char* blocker : {"blocker1", "blocker2"}) {
    ASSERT_TRUE(s.planners().Submit(blocker, [&] { release.WaitForNotification(); }).ok());
  }
  const bool held = Eventually([&] { return s.planners().running() == 2; });
  PacingAnswer a, moving;
  std::thread take_off([&] { a = PlanAt(s, "a", 0.0, 0.0); });
  const bool queued = held && Eventually([&] { return s.planners().waiting() == 1; });
  std::vector<PacingAnswer> refused;
  if (queued) {
    for (int attempt = 0; attempt < 2; ++attempt) refused.push_back(PlanAt(s, "b", 0.0, 0.0));
  }
  std::thread flying([&] { moving = PlanAt(s, "b", 0.0, 0.5, /*budget_s=*/0.2); });
  release.Notify();
  take_off.join();
  flying.join();
  ASSERT_TRUE(held);
  ASSERT_TRUE(queued);
  for (const PacingAnswer& r : refused) {
    ExpectPaced(r);
    EXPECT_THAT(r.status.error_message(), HasSubstr("(the limit)"));
  }
  EXPECT_TRUE(a.status.ok()) << a.status.error_message();
  EXPECT_TRUE(!moving.retry_header);
  EXPECT_NE(moving.status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED)
      << moving.status.error_message();
  const PacingAnswer admitted = PlanAt(s, "c", 0.0, 0.0);
  EXPECT_TRUE(admitted.status.ok()) << admitted.status.error_message();
  EXPECT_TRUE(!admitted.retry_header);
}

// With one planning thread: a blocker holds it and a replan of `flying` at
// `mission_time_s` waits behind it, until Release(). The blocker says when it
// runs: an earlier plan may still count as running, or the blocker as
// waiting, for a moment after its caller has its answer. Its notifications
// are shared with it, so that a blocker still queued or running when the
// helper goes (after a failed check) touches nothing freed.
class ReplanWaiting {
 public:
  ReplanWaiting(InProcessService& s, const std::string& flying, double mission_time_s)
      : blocker_(std::make_shared<Blocker>()) {
    held_ = s.planners()
                .Submit("blocker",
                        [blocker = blocker_] {
                          blocker->running.Notify();
                          blocker->release.WaitForNotification();
                        })
                .ok() &&
            blocker_->running.WaitForNotificationWithTimeout(absl::Seconds(30));
    if (!held_) return;
    replan_thread_ = std::thread(
        [&s, this, flying, mission_time_s] { replan_ = PlanAt(s, flying, mission_time_s, 0.0); });
    queued_ = Eventually([&] { return s.planners().waiting() == 1; });
  }
  ~ReplanWaiting() { (void)Release(); }
  [[nodiscard]] bool queued() const { return queued_; }
  // Lets the blocker and the replan run; the replan's answer.
  const PacingAnswer& Release() {
    if (!released_) {
      released_ = true;
      if (!blocker_->release.HasBeenNotified()) blocker_->release.Notify();
      if (replan_thread_.joinable()) replan_thread_.join();
    }
    return replan_;
  }

 private:
  struct Blocker {
    absl::Notification running, release;
  };
  std::shared_ptr<Blocker> blocker_;
  bool held_ = false, queued_ = false, released_ = false;
  std::thread replan_thread_;
  PacingAnswer replan_;
};

// A replan waiting for the only thread keeps take-offs on the ground even
// below the take-off limit; the replan itself is never paced.
TEST(ServiceTest, TakeOffsWaitWhileReplansQueue) {
  InProcessService s({.max_missions = 8, .max_cells_per_mission = 1600}, /*planning_threads=*/1,
                     /*planning_queue=*/8, nullptr, nullptr, {.max_take_off_plans = 2});
  for (const char* id : {"flying", "grounded"}) CreateSmall(s.stub(), id);
  ReplanWaiting waiting(s, "flying", 5.0);
  ASSERT_TRUE(waiting.queued());
  const PacingAnswer refused = PlanAt(s, "grounded", 0.0, 0.0);
  const PacingAnswer& replan = waiting.Release();
  ExpectPaced(refused);
  EXPECT_THAT(refused.status.error_message(), HasSubstr("1 plans wait for 1 planning threads"));
  EXPECT_TRUE(replan.status.ok()) << replan.status.error_message();
  EXPECT_TRUE(!replan.retry_header);
  const PacingAnswer admitted = PlanAt(s, "grounded", 0.0, 0.0);
  EXPECT_TRUE(admitted.status.ok()) << admitted.status.error_message();
}

// Past the patience since its first refusal, a take-off is no longer held
// back by a waiting replan (before it, it is), but the take-off limit still
// holds; once it has flown, a new take-off waits afresh. The service's clock
// is moved by hand past the patience.
TEST(ServiceTest, TakeOffsWaitForReplansOnlyUntilThePatience) {
  ManualClock clock;
  InProcessService s(
      {.max_missions = 8, .max_cells_per_mission = 1600}, /*planning_threads=*/1,
      /*planning_queue=*/8, nullptr, nullptr,
      {.max_take_off_plans = 1, .take_off_patience = absl::Seconds(1), .clock = &clock});
  for (const char* id : {"flying", "grounded", "other"}) CreateSmall(s.stub(), id);
  {
    ReplanWaiting waiting(s, "flying", 5.0);
    ASSERT_TRUE(waiting.queued());
    const PacingAnswer first = PlanAt(s, "grounded", 0.0, 0.0);
    const PacingAnswer again = PlanAt(s, "grounded", 0.0, 0.0);
    clock.Advance(absl::Milliseconds(1200));
    PacingAnswer patient;
    std::thread grounded([&] { patient = PlanAt(s, "grounded", 0.0, 0.0); });
    const bool admitted = Eventually([&] { return s.planners().waiting() == 2; });
    const PacingAnswer other = admitted ? PlanAt(s, "other", 0.0, 0.0) : PacingAnswer{};
    const PacingAnswer& replan = waiting.Release();
    grounded.join();
    for (const PacingAnswer* held : {&first, &again}) {
      ExpectPaced(*held);
      EXPECT_THAT(held->status.error_message(), HasSubstr("1 plans wait for 1 planning threads"));
    }
    ASSERT_TRUE(admitted);
    EXPECT_TRUE(patient.status.ok()) << patient.status.error_message();
    EXPECT_TRUE(!patient.retry_header);
    ExpectPaced(other);
    EXPECT_THAT(other.status.error_message(), HasSubstr("(the limit)"));
    EXPECT_TRUE(replan.status.ok()) << replan.status.error_message();
  }
  // Flown: its wait is over, so a new take-off behind a waiting replan is
  // held back again.
  ReplanWaiting waiting(s, "flying", 10.0);
  ASSERT_TRUE(waiting.queued());
  const PacingAnswer anew = PlanAt(s, "grounded", 0.0, 0.0);
  const PacingAnswer& replan = waiting.Release();
  ExpectPaced(anew);
  EXPECT_THAT(anew.status.error_message(), HasSubstr("1 plans wait for 1 planning threads"));
  EXPECT_TRUE(replan.status.ok()) << replan.status.error_message();
}

// Plans queued together share the time until the newest one's bound: the
// first to start does not search for all of its own bound while the others
// wait, and no search is allowed past its plan's bound (each would run far
// longer: 50 000 generations). Checked on the budgets the server granted
// (stats.search_budget_s), which follow from the queue, not on how long the
// searches took on this machine.
TEST(ServiceTest, PlansQueuedTogetherShareTheTimeUntilTheBound) {
  constexpr absl::Duration kBound = absl::Seconds(4);
  constexpr double kBoundS = 4.0;
  constexpr int kPlans = 4;
  InProcessService s({.max_missions = 8, .max_cells_per_mission = 1600}, /*planning_threads=*/1,
                     /*planning_queue=*/8, nullptr, nullptr, {.plan_latency = kBound});
  std::vector<grpc::Status> statuses;
  std::vector<v1::PlanPathResponse> paths;
  std::vector<int> answered;
  ASSERT_NO_FATAL_FAILURE(PlanQueuedTogether(s, "q", kPlans, 50000, &statuses, &paths, &answered));
  ASSERT_EQ(answered.size(), static_cast<std::size_t>(kPlans));
  for (int i = 0; i < kPlans; ++i) {
    ASSERT_TRUE(statuses[i].ok()) << statuses[i].error_message();
    const v1::PlannerStats& stats = paths[i].stats();
    EXPECT_EQ(stats.stop_reason(), "deadline") << i;
    EXPECT_TRUE(paths[i].collision_free()) << i;
    // Within the bound: the wait and the search together, unless the wait
    // left less than a hundredth of it.
    EXPECT_GT(stats.search_budget_s(), 0.0) << i;
    EXPECT_LE(stats.search_budget_s(), std::max(kBoundS - stats.queued_s(), kBoundS / 100) + 1e-6)
        << i << ": queued " << stats.queued_s() << " s";
  }
  // One planning thread: the first to start waited least. It had the 3
  // others queued behind it, all asked before it started: at most a
  // quarter of the bound was its. (The order the answers reach their
  // callers need not be the order the plans ran in on a loaded machine.)
  const auto first = std::min_element(paths.begin(), paths.end(), [](const auto& a, const auto& b) {
    return a.stats().queued_s() < b.stats().queued_s();
  });
  EXPECT_LE(first->stats().search_budget_s(), kBoundS / kPlans + 1e-6);
}

// The planner is anytime: with far more generations than fit before the
// call's deadline, the best path found by then still reaches the client.
TEST(ServiceTest, PlanPathAnswersWithinTheCallsDeadline) {
  InProcessService s;
  grpc::ClientContext create_context;
  v1::CreateMissionRequest create;
  create.set_mission_id("slow");
  *create.mutable_spec() = SmallSpec();
  create.mutable_spec()->mutable_planner()->set_generations(100000);
  v1::Mission mission;
  ASSERT_TRUE(s.stub().CreateMission(&create_context, create, &mission).ok());
  v1::PlanPathRequest request;
  request.set_name("missions/slow");
  request.mutable_state()->mutable_position_m()->set_x(-4);
  request.mutable_state()->mutable_position_m()->set_y(4);
  request.mutable_state()->mutable_position_m()->set_z(8);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(1500));
  v1::PlanPathResponse path;
  const grpc::Status status = s.stub().PlanPath(&context, request, &path);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(path.stats().stop_reason(), "deadline");
  EXPECT_TRUE(path.collision_free());
}

// planning_budget_s bounds the planner without a call deadline: the best
// path at the budget comes back, and a bad budget names the field.
TEST(ServiceTest, PlanningBudgetStopsThePlannerWithoutADeadline) {
  InProcessService s;
  grpc::ClientContext create_context;
  v1::CreateMissionRequest create;
  create.set_mission_id("budget");
  *create.mutable_spec() = SmallSpec();
  create.mutable_spec()->mutable_planner()->set_generations(100000);
  v1::Mission mission;
  ASSERT_TRUE(s.stub().CreateMission(&create_context, create, &mission).ok());
  v1::PlanPathRequest request;
  request.set_name("missions/budget");
  request.mutable_state()->mutable_position_m()->set_x(-4);
  request.mutable_state()->mutable_position_m()->set_y(4);
  request.mutable_state()->mutable_position_m()->set_z(8);
  request.set_planning_budget_s(0.5);
  {
    grpc::ClientContext context;  // no deadline
    v1::PlanPathResponse path;
    const grpc::Status status = s.stub().PlanPath(&context, request, &path);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_EQ(path.stats().stop_reason(), "deadline");
    EXPECT_TRUE(path.collision_free());
    EXPECT_LT(path.stats().generations(), 1000000);
  }
  for (double bad : {0.0, -1.0, std::nan("")}) {
    request.set_planning_budget_s(bad);
    grpc::ClientContext context;
    v1::PlanPathResponse path;
    const grpc::Status status = s.stub().PlanPath(&context, request, &path);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << bad;
    EXPECT_THAT(status.error_message(), HasSubstr("planning_budget_s: must be > 0"));
  }
}

// A plan from the corner with `budget_s` of planning and a 20 s deadline.
grpc::Status PlanWithBudget(v1::MissionService::Stub& stub, const std::string& id, double budget_s,
                            v1::PlanPathResponse* path) {
  v1::PlanPathRequest request = PlanFromCorner(id);
  request.set_planning_budget_s(budget_s);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(20));
  return stub.PlanPath(&context, request, path);
}

// A cancelled plan stops planning and gives its slot back: with one
// planning thread, another mission's plan then gets through well within its
// deadline. (Before, the cancelled plan ran on and the other waited out its
// deadline.)
TEST(ServiceTest, ACancelledPlanGivesThePlannerBack) {
  InProcessService s({.max_missions = 8, .max_cells_per_mission = 1600}, /*planning_threads=*/1);
  CreateEndless(s.stub(), "endless");
  CreateEndless(s.stub(), "other");
  grpc::ClientContext endless_context;  // no deadline, no budget: until cancelled
  std::thread endless([&] {
    v1::PlanPathResponse path;
    const grpc::Status status =
        s.stub().PlanPath(&endless_context, PlanFromCorner("endless"), &path);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::CANCELLED) << status.error_message();
  });
  ASSERT_TRUE(Eventually([&] { return s.planners().running() == 1; }));  // it holds the slot
  endless_context.TryCancel();
  v1::PlanPathResponse path;
  const grpc::Status status = PlanWithBudget(s.stub(), "other", 0.5, &path);
  EXPECT_TRUE(status.ok()) << status.error_message();
  endless.join();
}

// planning_budget_s counts planning, not the wait for a slot: behind a
// 2 s plan, a 0.5 s budget with a 20 s deadline waits, then plans.
TEST(ServiceTest, ThePlanningBudgetStartsWhenAPlannerIsFree) {
  InProcessService s({.max_missions = 8, .max_cells_per_mission = 1600}, /*planning_threads=*/1);
  CreateEndless(s.stub(), "first");
  CreateEndless(s.stub(), "second");
  std::thread first([&] {
    v1::PlanPathRequest request = PlanFromCorner("first");
    request.set_planning_budget_s(2.0);
    grpc::ClientContext context;
    v1::PlanPathResponse path;
    EXPECT_TRUE(s.stub().PlanPath(&context, request, &path).ok());
  });
  ASSERT_TRUE(Eventually([&] { return s.planners().running() == 1; }));  // it holds the slot
  v1::PlanPathResponse path;
  const grpc::Status status = PlanWithBudget(s.stub(), "second", 0.5, &path);
  EXPECT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(path.stats().stop_reason(), "deadline");  // it did plan, for its budget
  first.join();
}

// A long plan holds its own mission's planner, nothing else: creating and
// reading missions (which also report memory for the metrics) go on while it
// runs. Checked by order: they return while the plan, whose budget is far
// longer than they could take, still runs; the test then cancels it.
TEST(ServiceTest, CallsDoNotWaitForAnotherMissionsPlan) {
  InProcessService s;
  grpc::ClientContext create_context;
  v1::CreateMissionRequest create;
  create.set_mission_id("long");
  *create.mutable_spec() = SmallSpec();
  create.mutable_spec()->mutable_planner()->set_generations(100000);
  v1::Mission mission;
  ASSERT_TRUE(s.stub().CreateMission(&create_context, create, &mission).ok());
  std::atomic<bool> plan_returned{false};
  grpc::ClientContext plan_context;
  grpc::Status plan_status;
  std::thread planner([&] {
    v1::PlanPathRequest request;
    request.set_name("missions/long");
    request.mutable_state()->mutable_position_m()->set_x(-4);
    request.mutable_state()->mutable_position_m()->set_y(4);
    request.mutable_state()->mutable_position_m()->set_z(8);
    request.set_planning_budget_s(50.0);
    v1::PlanPathResponse path;
    plan_status = s.stub().PlanPath(&plan_context, request, &path);
    plan_returned = true;
  });
  ASSERT_TRUE(Eventually([&] { return s.planners().running() == 1; }));  // the plan runs
  CreateSmall(s.stub(), "other");
  {
    grpc::ClientContext context;
    v1::GetMissionRequest get;
    get.set_name("missions/long");
    v1::Mission got;
    ASSERT_TRUE(s.stub().GetMission(&context, get, &got).ok());
    EXPECT_EQ(got.paths_planned(), 0);
  }
  EXPECT_FALSE(plan_returned.load()) << "CreateMission / GetMission waited for the plan";
  plan_context.TryCancel();
  planner.join();
  EXPECT_EQ(plan_status.error_code(), grpc::StatusCode::CANCELLED) << plan_status.error_message();
}

TEST(ServiceTest, SpentBudgetIsAFailedPrecondition) {
  InProcessService s;
  CreateSmall(s.stub(), "b");  // 60 s budget
  v1::PlanPathRequest request;
  request.set_name("missions/b");
  request.mutable_state()->mutable_position_m()->set_x(-4);
  request.mutable_state()->mutable_position_m()->set_y(4);
  request.mutable_state()->mutable_position_m()->set_z(8);
  request.mutable_state()->set_mission_time_s(61);
  v1::PlanPathResponse path;
  grpc::ClientContext context;
  const grpc::Status status = s.stub().PlanPath(&context, request, &path);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(status.error_message(), HasSubstr("budget"));
}

TEST(ServiceTest, GetMapGivesCellsTraceAndAPng) {
  InProcessService s;
  const v1::Mission m = CreateSmall(s.stub(), "g");
  grpc::ClientContext context;
  v1::GetMapRequest request;
  request.set_name("missions/g");
  request.set_include_cells(true);
  request.set_include_png(true);
  v1::GetMapResponse map;
  ASSERT_TRUE(s.stub().GetMap(&context, request, &map).ok());
  EXPECT_EQ(map.nx(), 20);
  EXPECT_EQ(map.ny(), 20);
  EXPECT_EQ(map.mean_size(), 400);
  EXPECT_EQ(map.variance_size(), 400);
  double trace = 0;
  for (double v : map.variance()) trace += v;
  EXPECT_NEAR(trace, map.trace(), 1e-9);
  EXPECT_DOUBLE_EQ(map.trace(), m.trace());
  ASSERT_GT(map.png().size(), 8u);
  EXPECT_EQ(map.png().substr(1, 3), "PNG");
}

TEST(ServiceTest, WatchMissionStreamsEventsUntilDeleted) {
  InProcessService s;
  CreateSmall(s.stub(), "w");
  grpc::ClientContext watch_context;
  v1::WatchMissionRequest watch;
  watch.set_name("missions/w");
  auto reader = s.stub().WatchMission(&watch_context, watch);
  // Once the stream has subscribed, two events.
  std::thread actor([&] {
    EXPECT_TRUE(
        Eventually([&] { return (*s.registry().Get("missions/w"))->events().watchers() == 1; }));
    grpc::ClientContext c1;
    v1::AddMeasurementResponse r;
    EXPECT_TRUE(
        s.stub().AddMeasurement(&c1, LabelMeasurement("missions/w", 1, 1, 9, 3, 0), &r).ok());
    grpc::ClientContext c2;
    v1::DeleteMissionRequest del;
    del.set_name("missions/w");
    v1::DeleteMissionResponse d;
    EXPECT_TRUE(s.stub().DeleteMission(&c2, del, &d).ok());
  });
  std::vector<v1::MissionEvent> events;
  v1::MissionEvent event;
  while (reader->Read(&event)) events.push_back(event);
  actor.join();
  EXPECT_TRUE(reader->Finish().ok());
  ASSERT_EQ(events.size(), 2u);
  EXPECT_TRUE(events[0].has_measurement_fused());
  EXPECT_EQ(events[0].measurement_fused().cells_fused(), 9);
  EXPECT_TRUE(events[1].has_mission_deleted());
  EXPECT_LT(events[0].sequence(), events[1].sequence());
}

TEST(ServiceTest, LimitsAreResourceExhausted) {
  InProcessService s({.max_missions = 2, .max_cells_per_mission = 400});
  CreateSmall(s.stub(), "one");
  CreateSmall(s.stub(), "two");
  grpc::ClientContext context;
  v1::CreateMissionRequest request;
  request.set_mission_id("three");
  *request.mutable_spec() = SmallSpec();
  v1::Mission m;
  EXPECT_EQ(s.stub().CreateMission(&context, request, &m).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED);
  // A 40 x 40 field is 1600 cells: over this server's 400.
  grpc::ClientContext big_context;
  request.set_mission_id("big");
  request.mutable_spec()->clear_field();
  const grpc::Status big = s.stub().CreateMission(&big_context, request, &m);
  EXPECT_EQ(big.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(big.error_message(), HasSubstr("cells"));
}

}  // namespace
}  // namespace oaipp::server
