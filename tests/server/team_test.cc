// Several UAVs on one mission (docs/teams.md), through the service in
// process: the team spec refused with the field named, every call naming its
// UAV, plans that keep min_separation_m from every teammate's committed
// trajectory (checked here by this file's own evaluation of the returned
// polynomials at 100 Hz) and say which teammates' versions they were checked
// against, and committed trajectories that come back after a restart, from
// the log and from a snapshot.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "server/store/sqlite_store.h"
#include "tests/server/service_fixture.h"
#include "tests/server/team_fixture.h"

namespace oaipp::server {
namespace {

using testing::At;
using testing::ClosestApproach;
using testing::CreateTeam;
using testing::EndOf;
using testing::Flight;
using ::testing::HasSubstr;
using testing::InProcessService;
using testing::kSeparation;
using testing::PlanFor;
using testing::Point;
using testing::PositionAt;
using testing::TeamSpec;

class TeamTest : public testing::TeamStoreTest {};

TEST_F(TeamTest, ABadTeamIsRefusedNamingTheField) {
  InProcessService service(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600});
  const std::vector<Point> two = {{-8, 8, 8}, {8, 8, 8}};
  struct Case {
    const char* what;
    v1::MissionSpec spec;
    const char* field;
  };
  std::vector<Case> cases;
  {
    std::vector<Point> many;
    for (int i = 0; i < 17; ++i) many.push_back({-14.0 + 1.7 * i, 12, 8});
    cases.push_back({"17 UAVs", TeamSpec(many), "spec.team"});
  }
  {
    v1::MissionSpec s = TeamSpec(two);
    s.mutable_team(1)->set_uav_id("a");
    cases.push_back({"a duplicate id", s, "spec.team[1].uav_id"});
  }
  {
    v1::MissionSpec s = TeamSpec(two);
    s.mutable_team(0)->set_uav_id("Not_An_Id");
    cases.push_back({"a bad id", s, "spec.team[0].uav_id"});
  }
  {
    v1::MissionSpec s = TeamSpec(two);
    s.mutable_team(1)->clear_start();
    cases.push_back({"no start", s, "spec.team[1].start"});
  }
  cases.push_back(
      {"starts too close", TeamSpec({{-8, 8, 8}, {-6, 8, 8}}), "spec.team[1].start.position_m"});
  {
    v1::MissionSpec s = TeamSpec(two);
    s.set_silent_after_s(0);
    cases.push_back({"no time to fall silent", s, "spec.silent_after_s"});
  }
  {
    v1::MissionSpec s = TeamSpec(two);
    s.mutable_team(1)->mutable_flight()->set_tracking_error_m(11);
    cases.push_back({"a member's tracking error", s, "spec.team[1].flight.tracking_error_m"});
  }
  {
    v1::MissionSpec s = TeamSpec(two);
    s.mutable_planner()->set_kind(v1::PLANNER_KIND_LAWNMOWER);
    cases.push_back({"the lawnmower", s, "spec.planner.kind"});
  }
  {
    v1::MissionSpec s = TeamSpec(two);
    s.set_min_separation_m(0.5);  // below uav_radius_m (1 m)
    cases.push_back({"separation below the radius", s, "spec.min_separation_m"});
  }
  {
    v1::MissionSpec s = TeamSpec(two);
    s.mutable_team(1)->mutable_start()->set_mission_time_s(3);
    cases.push_back({"two clocks", s, "spec.team[1].start.mission_time_s"});
  }
  cases.push_back({"a start in the building", TeamSpec({{-8, 8, 8}, {0, -2, 8}}),
                   "spec.team[1].start.position_m"});
  {
    v1::MissionSpec s = TeamSpec(two);
    s.mutable_team(1)->mutable_start()->mutable_position_m()->set_z(100);
    cases.push_back({"a start above the volume", s, "spec.team[1].start.position_m"});
  }
  {
    v1::MissionSpec s = TeamSpec(two);
    s.mutable_team(1)->mutable_flight()->set_max_altitude_m(20);
    cases.push_back({"a member's own altitudes", s, "spec.team[1].flight.max_altitude_m"});
  }
  {
    v1::MissionSpec s = TeamSpec(two);
    s.mutable_team(0)->mutable_flight()->set_esdf_voxel_m(0.5);
    cases.push_back({"a member's own ESDF", s, "spec.team[0].flight.esdf_voxel_m"});
  }
  {
    v1::MissionSpec s = TeamSpec(two);
    s.mutable_team(1)->mutable_flight()->set_uav_radius_m(kSeparation + 1);
    cases.push_back({"a member wider than the separation", s, "spec.team[1].flight.uav_radius_m"});
  }
  {
    v1::MissionSpec s = TeamSpec(two);
    s.mutable_team(1)->mutable_flight()->set_max_speed_m_s(-1);
    cases.push_back({"a member's negative speed", s, "spec.team[1].flight.max_speed_m_s"});
  }
  {
    v1::MissionSpec s = TeamSpec(two);
    s.mutable_team(0)->mutable_sensor()->set_fov_x_deg(200);
    cases.push_back({"a member's field of view", s, "spec.team[0].sensor.fov_x_deg"});
  }
  {
    v1::MissionSpec s = TeamSpec(two);
    s.mutable_team(1)->mutable_sensor()->set_rate_hz(0);
    cases.push_back({"a member's camera that never fires", s, "spec.team[1].sensor.rate_hz"});
  }
  {
    v1::MissionSpec s = TeamSpec(two);
    s.mutable_team(1)->mutable_sensor()->set_noise_a_var(2);
    s.mutable_team(1)->mutable_sensor()->mutable_detector_noise()->set_p_max(0.9);
    cases.push_back({"a member's two noise models", s, "spec.team[1].sensor.detector_noise"});
  }
  {
    v1::MissionSpec s = TeamSpec(two);
    s.mutable_team(1)->mutable_sensor()->mutable_detector_noise()->set_p_max(1.5);
    cases.push_back({"a member's bad detector", s, "spec.team[1].sensor.detector_noise.p_max"});
  }
  {
    // Within the mission's speed (5 m/s), beyond the member's own.
    v1::MissionSpec s = TeamSpec(two);
    s.mutable_team(1)->mutable_flight()->set_max_speed_m_s(2);
    s.mutable_team(1)->mutable_start()->mutable_velocity_m_s()->set_x(3);
    cases.push_back(
        {"a start faster than the member may fly", s, "spec.team[1].start.velocity_m_s"});
  }
  {
    // Clear of the building by the mission's radius / 2, not by the member's.
    v1::MissionSpec s = TeamSpec({{-8, 8, 8}, {2.8, -2, 8}});
    s.mutable_team(1)->mutable_flight()->set_uav_radius_m(3.8);
    cases.push_back(
        {"a start too close for the member's radius", s, "spec.team[1].start.position_m"});
  }
  {
    v1::MissionSpec s = testing::SmallSpec();  // one UAV: no teammates' shots to count
    s.set_count_teammate_shots(false);
    cases.push_back({"count_teammate_shots without a team", s, "spec.count_teammate_shots"});
  }
  for (const Case& c : cases) {
    v1::Mission out;
    const grpc::Status status = CreateTeam(service.stub(), "t", c.spec, &out);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.what;
    EXPECT_THAT(status.error_message(), HasSubstr(c.field)) << c.what;
  }
  EXPECT_EQ(service.registry().size(), 0u);
}

TEST_F(TeamTest, EveryCallNamesAUavOfTheTeam) {
  InProcessService service(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600});
  v1::Mission team;
  ASSERT_TRUE(CreateTeam(service.stub(), "t", TeamSpec({{-8, 8, 8}, {8, 8, 8}}), &team).ok());
  ASSERT_EQ(team.spec().team_size(), 2);
  EXPECT_EQ(team.spec().min_separation_m(), kSeparation);
  v1::PlanPathResponse plan;
  grpc::Status s = PlanFor(service.stub(), "t", "", At({-8, 8, 8}, 0), "p0", &plan);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(s.error_message(), HasSubstr("uav_id"));
  s = PlanFor(service.stub(), "t", "zz", At({-8, 8, 8}, 0), "p1", &plan);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_THAT(s.error_message(), HasSubstr("uav_id"));
  // A measurement over (-8, 8) from UAV `uav`.
  auto measure = [&](const std::string& uav, v1::AddMeasurementResponse* fused) {
    grpc::ClientContext c;
    v1::AddMeasurementRequest r = testing::LabelMeasurement("missions/t", -8, 8, 8, 1.0, 0.0);
    r.set_uav_id(uav);
    return service.stub().AddMeasurement(&c, r, fused);
  };
  v1::AddMeasurementResponse fused;
  s = measure("zz", &fused);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_THAT(s.error_message(), HasSubstr("uav_id"));
  ASSERT_TRUE(measure("b", &fused).ok());
  EXPECT_EQ(fused.measurements_fused(), 1);  // the refused ones changed nothing
  // A mission without a team knows only uav_id "".
  v1::Mission single = testing::CreateSmall(service.stub(), "single");
  v1::PlanPathRequest r = testing::PlanFromCorner("single");
  r.set_uav_id("a");
  grpc::ClientContext c;
  s = service.stub().PlanPath(&c, r, &plan);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_THAT(s.error_message(), HasSubstr("uav_id"));
}

// Each plan keeps apart from the teammates' trajectories of the moment and
// names their versions; a UAV that has not planned is held at its start.
TEST_F(TeamTest, PlansKeepApartAndNameTheTeammatesTheyWereCheckedAgainst) {
  InProcessService service(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600});
  // a and b start 5 m apart, side by side: left alone, their paths cross.
  const std::vector<Point> starts = {{-2.5, 8, 8}, {2.5, 8, 8}, {-8, -8, 8}};
  v1::Mission team;
  ASSERT_TRUE(CreateTeam(service.stub(), "t", TeamSpec(starts), &team).ok());
  std::map<std::string, Flight> flights;
  for (std::size_t i = 0; i < starts.size(); ++i) {
    flights[std::string(1, static_cast<char>('a' + i))].hold = starts[i];
  }
  // a, b, c from their starts, then a again from where its path has it 3 s on.
  std::int64_t version = 0;
  for (const std::string uav : {"a", "b", "c", "a"}) {
    const double now = uav == "a" && version > 0 ? 3.0 : 0.0;
    const Point from = PositionAt(flights[uav], now);
    v1::PlanPathResponse plan;
    const grpc::Status s =
        PlanFor(service.stub(), "t", uav, At(from, now), absl::StrCat("p", version), &plan);
    ASSERT_TRUE(s.ok()) << uav << ": " << s.error_message();
    EXPECT_EQ(plan.uav_id(), uav);
    EXPECT_EQ(plan.plan_version(), ++version);
    EXPECT_EQ(plan.start_mission_s(), now);
    std::vector<std::pair<std::string, std::int64_t>> checked, expected;
    for (const v1::TeammatePlan& m : plan.checked_against()) {
      checked.emplace_back(m.uav_id(), m.plan_version());
    }
    for (const auto& [id, f] : flights) {
      if (id != uav) expected.emplace_back(id, f.path.plan_version());
    }
    EXPECT_EQ(checked, expected) << uav;
    flights[uav].path = plan;
    for (const auto& [id, f] : flights) {
      if (id == uav) continue;
      EXPECT_GE(ClosestApproach(flights[uav], f, now), kSeparation - 1e-6) << uav << " vs " << id;
    }
  }
}

// count_teammate_shots (default true) decides whether a teammate's pending
// shots count as taken in a plan's objective. The random planner picks the
// first safe destination its seed draws, whatever it scores: b's path is
// then the same in both missions (a's, planned first, is too), and only the
// information b reports can tell them apart. With a's shots counted, b
// expects to learn less over the ground they share.
TEST_F(TeamTest, TeammatesPendingShotsCountUnlessTheSpecSaysNot) {
  InProcessService service(RegistryLimits{.max_missions = 64, .max_cells_per_mission = 1600});
  const std::vector<Point> starts = {{-3, 8, 8}, {3, 8, 8}};
  // The first planner seed whose path for b earns something (a path whose
  // only shot is the unscored one at its start earns 0 either way).
  bool compared = false;
  for (std::uint32_t seed = 1; seed <= 10 && !compared; ++seed) {
    std::map<std::string, v1::PlanPathResponse> a, b;
    for (const std::string mode : {"counted", "ignored"}) {
      v1::MissionSpec spec = TeamSpec(starts);
      spec.mutable_planner()->set_kind(v1::PLANNER_KIND_RANDOM);
      spec.mutable_planner()->set_seed(seed);
      if (mode == "ignored") spec.set_count_teammate_shots(false);
      const std::string id = absl::StrCat(mode, "-", seed);
      v1::Mission team;
      ASSERT_TRUE(CreateTeam(service.stub(), id, spec, &team).ok()) << id;
      EXPECT_EQ(team.spec().count_teammate_shots(), mode == "counted") << id;
      ASSERT_TRUE(PlanFor(service.stub(), id, "a", At(starts[0], 0), "pa", &a[mode]).ok()) << id;
      const grpc::Status s = PlanFor(service.stub(), id, "b", At(starts[1], 0), "pb", &b[mode]);
      ASSERT_TRUE(s.ok()) << id << ": " << s.error_message();
    }
    EXPECT_EQ(a["counted"].information(), a["ignored"].information()) << seed;
    ASSERT_EQ(b["counted"].control_waypoints_m_size(), b["ignored"].control_waypoints_m_size());
    for (int i = 0; i < b["counted"].control_waypoints_m_size(); ++i) {
      EXPECT_EQ(b["counted"].control_waypoints_m(i).x(), b["ignored"].control_waypoints_m(i).x());
      EXPECT_EQ(b["counted"].control_waypoints_m(i).y(), b["ignored"].control_waypoints_m(i).y());
      EXPECT_EQ(b["counted"].control_waypoints_m(i).z(), b["ignored"].control_waypoints_m(i).z());
    }
    if (b["ignored"].information() <= 0.0 || a["counted"].measurement_poses_size() < 2) continue;
    EXPECT_LT(b["counted"].information(), 0.9 * b["ignored"].information()) << seed;
    compared = true;
  }
  EXPECT_TRUE(compared) << "no seed in 1-10 gave b a path that earns anything";
}

// A teammate's shot counts as still to come only while it is not in the
// map: at or after the plan's start and after that teammate's latest
// measurement. Teammates shoot on one clock and plan at their shots, so a
// shot at the plan's own start is often fused already; counted again, its
// ground would be taken as seen twice. Every count is the number of a's
// poses computed here from a's own path.
TEST_F(TeamTest, ATeammatesShotAlreadyFusedIsNotCountedAgain) {
  InProcessService service(RegistryLimits{.max_missions = 64, .max_cells_per_mission = 1600});
  const std::vector<Point> starts = {{-3, 8, 8}, {3, 8, 8}};
  for (const bool counted : {true, false}) {
    v1::MissionSpec spec = TeamSpec(starts);
    spec.set_count_teammate_shots(counted);
    const std::string id = counted ? "counted" : "ignored";
    v1::Mission team;
    ASSERT_TRUE(CreateTeam(service.stub(), id, spec, &team).ok());
    v1::PlanPathResponse a;
    ASSERT_TRUE(PlanFor(service.stub(), id, "a", At(starts[0], 0), "pa", &a).ok());
    const auto poses_after = [&](double t_s, bool strictly) {
      int n = 0;
      for (const v1::MeasurementPose& pose : a.measurement_poses()) {
        n += strictly ? pose.mission_time_s() > t_s : pose.mission_time_s() >= t_s;
      }
      return n;
    };
    ASSERT_GE(a.measurement_poses_size(), 2);
    ASSERT_EQ(a.measurement_poses(0).mission_time_s(), 0.0);  // its start shot, at 0
    const auto b_counts = [&](const std::string& request_id) {
      v1::PlanPathResponse b;
      EXPECT_TRUE(PlanFor(service.stub(), id, "b", At(starts[1], 0), request_id, &b).ok());
      EXPECT_EQ(b.checked_against_size(), 1);
      return b.checked_against_size() == 1 ? b.checked_against(0).shots_counted() : -1;
    };
    // Before a's start shot is fused: every pose of a's path is to come.
    EXPECT_EQ(b_counts("pb1"), counted ? poses_after(0.0, false) : 0) << id;
    // a takes its start shot: it is in the map, and counts no more.
    {
      grpc::ClientContext c;
      const v1::MeasurementPose& shot = a.measurement_poses(0);
      v1::AddMeasurementRequest r =
          testing::LabelMeasurement("missions/" + id, shot.position_m().x(), shot.position_m().y(),
                                    shot.position_m().z(), shot.mission_time_s(), 0.0);
      r.set_uav_id("a");
      r.set_request_id("ma");
      v1::AddMeasurementResponse fused;
      ASSERT_TRUE(service.stub().AddMeasurement(&c, r, &fused).ok());
    }
    EXPECT_EQ(b_counts("pb2"), counted ? poses_after(0.0, true) : 0) << id;
    EXPECT_EQ(poses_after(0.0, true), a.measurement_poses_size() - 1);
    // a's next shot, stamped by its camera 10 ms before its planned time,
    // is that shot too.
    {
      grpc::ClientContext c;
      const v1::MeasurementPose& shot = a.measurement_poses(1);
      v1::AddMeasurementRequest r =
          testing::LabelMeasurement("missions/" + id, shot.position_m().x(), shot.position_m().y(),
                                    shot.position_m().z(), shot.mission_time_s() - 0.01, 0.0);
      r.set_uav_id("a");
      r.set_request_id("ma2");
      v1::AddMeasurementResponse fused;
      ASSERT_TRUE(service.stub().AddMeasurement(&c, r, &fused).ok());
    }
    EXPECT_EQ(b_counts("pb3"),
              counted ? poses_after(a.measurement_poses(1).mission_time_s(), true) : 0)
        << id;
    EXPECT_EQ(poses_after(a.measurement_poses(1).mission_time_s(), true),
              a.measurement_poses_size() - 2);
  }
}

// The committed trajectories are durable: a server started on the same store
// checks the next plan against them, whether it replays the log or restores
// a snapshot, and a retried plan gets its first answer.
TEST_F(TeamTest, CommittedTrajectoriesComeBackAfterARestart) {
  constexpr double kRateHz = 0.15;  // the camera's, set: the shots' counts below depend on it
  const std::vector<Point> starts = {{-8, 8, 8}, {8, 8, 8}, {-8, -8, 8}};
  for (const int snapshot_every : {0, 1}) {
    SCOPED_TRACE(snapshot_every == 0 ? "from the log" : "from a snapshot");
    const RegistryLimits limits = FreshStore(snapshot_every);
    std::unique_ptr<MissionStore> store = Open();
    v1::PlanPathResponse a, b;
    {
      InProcessService before(limits, 2, 64, store.get());
      v1::Mission team;
      v1::MissionSpec spec = TeamSpec(starts);
      spec.mutable_sensor()->set_rate_hz(kRateHz);
      ASSERT_TRUE(CreateTeam(before.stub(), "t", spec, &team).ok());
      ASSERT_TRUE(PlanFor(before.stub(), "t", "a", At(starts[0], 0), "pa", &a).ok());
      {
        grpc::ClientContext c;
        v1::AddMeasurementRequest r = testing::LabelMeasurement("missions/t", 8, 8, 8, 0.5, 0.0);
        r.set_uav_id("b");
        r.set_request_id("mb");
        v1::AddMeasurementResponse fused;
        ASSERT_TRUE(before.stub().AddMeasurement(&c, r, &fused).ok());
      }
      ASSERT_TRUE(PlanFor(before.stub(), "t", "b", At(starts[1], 0), "pb", &b).ok());
      if (snapshot_every > 0) before.registry().FlushSnapshots();
    }
    InProcessService after(limits, 2, 64, store.get());
    ASSERT_TRUE(after.recovered().ok());
    v1::PlanPathResponse retried;
    ASSERT_TRUE(PlanFor(after.stub(), "t", "b", At(starts[1], 0), "pb", &retried).ok());
    EXPECT_EQ(retried.SerializeAsString(), b.SerializeAsString());
    v1::PlanPathResponse c;
    ASSERT_TRUE(PlanFor(after.stub(), "t", "c", At(starts[2], 0), "pc", &c).ok());
    EXPECT_EQ(c.plan_version(), 3);
    ASSERT_EQ(c.checked_against_size(), 2);
    EXPECT_EQ(c.checked_against(0).uav_id(), "a");
    EXPECT_EQ(c.checked_against(0).plan_version(), a.plan_version());
    EXPECT_EQ(c.checked_against(1).uav_id(), "b");
    EXPECT_EQ(c.checked_against(1).plan_version(), b.plan_version());
    EXPECT_GE(ClosestApproach({.path = c}, {.path = a}, 0.0), kSeparation - 1e-6);
    EXPECT_GE(ClosestApproach({.path = c}, {.path = b}, 0.0), kSeparation - 1e-6);
    // b's measurement at 0.5 s comes back too: b's shots until half a
    // camera period after it are in the map, and c counts only the later
    // ones; all of a's.
    const double half_period_s = 0.5 / kRateHz;
    const auto later = [](const v1::PlanPathResponse& path, double t_s) {
      int n = 0;
      for (const v1::MeasurementPose& pose : path.measurement_poses()) {
        n += pose.mission_time_s() > t_s;
      }
      return n;
    };
    EXPECT_EQ(c.checked_against(0).shots_counted(), a.measurement_poses_size());
    EXPECT_EQ(c.checked_against(1).shots_counted(), later(b, 0.5 + half_period_s));
  }
}

// Randomised teams (2-8 UAVs at random starts among two buildings, seeded):
// every UAV plans twice, in a random order, and no two committed
// trajectories ever come closer than min_separation_m, by this file's own
// evaluation at 100 Hz. A team the server refuses (a start too close to the
// tower) is drawn again, so that `count` missions fly: 200 (in the slow
// tier), or OAIPP_RANDOM_TEAMS (docs/teams.md).
TEST_F(TeamTest, RandomTeamsNeverComeTooClose) {
  const char* asked = std::getenv("OAIPP_RANDOM_TEAMS");
  const int count = asked != nullptr ? std::max(1, std::atoi(asked)) : 200;
  InProcessService service(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600});
  std::mt19937 rng(20261201);
  std::uniform_real_distribution<double> xy(-13.0, 13.0), z(4.0, 20.0);
  int missions = 0, plans = 0, refused = 0, teams_refused = 0;
  for (int m = 0; missions < count && m < 2 * count; ++m) {
    const int size = 2 + static_cast<int>(rng() % 7);
    std::vector<Point> starts;
    while (static_cast<int>(starts.size()) < size) {
      const Point p{xy(rng), xy(rng), z(rng)};
      const bool clear_of_building = p.x < -2.5 || p.x > 2.5 || p.y < -5.5 || p.y > 1.5;
      bool apart = true;
      for (const Point& q : starts) {
        apart = apart && std::hypot(p.x - q.x, p.y - q.y, p.z - q.z) >= kSeparation + 1.0;
      }
      if (clear_of_building && apart) starts.push_back(p);
    }
    const std::string id = absl::StrCat("r", m);
    v1::MissionSpec spec = TeamSpec(starts);
    v1::Obstacle* tower = spec.add_obstacles();
    tower->set_id("tower");
    tower->mutable_cylinder()->mutable_centre_m()->set_x(8);
    tower->mutable_cylinder()->mutable_centre_m()->set_y(-8);
    tower->mutable_cylinder()->mutable_centre_m()->set_z(10);
    tower->mutable_cylinder()->set_radius_m(1.5);
    tower->mutable_cylinder()->set_height_m(20);
    spec.mutable_planner()->set_seed(static_cast<std::uint32_t>(m + 1));
    if (m % 3 == 2) spec.mutable_planner()->set_kind(v1::PLANNER_KIND_RANDOM);
    v1::Mission created;
    const grpc::Status made = CreateTeam(service.stub(), id, spec, &created);
    if (!made.ok()) {
      // A random start next to the tower: refused, and the case skipped.
      EXPECT_THAT(made.error_message(), HasSubstr("spec.team[")) << made.error_message();
      ++teams_refused;
      continue;
    }
    ++missions;
    std::map<std::string, Flight> flights;
    for (int i = 0; i < size; ++i) {
      flights[std::string(1, static_cast<char>('a' + i))].hold =
          starts[static_cast<std::size_t>(i)];
    }
    for (int round = 0; round < 2; ++round) {
      std::vector<std::string> ids;
      for (const auto& [uav, f] : flights) ids.push_back(uav);
      std::shuffle(ids.begin(), ids.end(), rng);
      for (const std::string& uav : ids) {
        const double now = 2.0 * round;
        v1::PlanPathResponse plan;
        const grpc::Status s =
            PlanFor(service.stub(), id, uav, At(PositionAt(flights[uav], now), now),
                    absl::StrCat(uav, round), &plan);
        if (!s.ok()) {
          // No safe path (boxed in by teammates): refused, never unsafe.
          EXPECT_EQ(s.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << s.error_message();
          ++refused;
          continue;
        }
        ++plans;
        flights[uav].path = plan;
        for (const auto& [other, f] : flights) {
          if (other == uav) continue;
          EXPECT_GE(ClosestApproach(flights[uav], f, now), kSeparation - 1e-6)
              << id << ": " << uav << " vs " << other;
        }
      }
    }
    grpc::ClientContext c;
    v1::DeleteMissionRequest del;
    del.set_name("missions/" + id);
    v1::DeleteMissionResponse deleted;
    ASSERT_TRUE(service.stub().DeleteMission(&c, del, &deleted).ok());
  }
  EXPECT_EQ(missions, count);
  EXPECT_GE(plans, 4 * missions);
  std::printf(
      "random teams: %d missions flown (%d teams refused at creation), %d plans, %d "
      "plans refused\n",
      missions, teams_refused, plans, refused);
}

}  // namespace
}  // namespace oaipp::server
