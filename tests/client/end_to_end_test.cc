// A short mission end to end: the real service in-process, the client over
// its channel, the E1 world with a 30 s budget. RSE must fall; no collision.
#include <cmath>
#include <memory>
#include <set>
#include <thread>
#include <vector>

#include "absl/synchronization/notification.h"
#include "client/cli/mission_runner.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "server/service.h"
#include "sim/scenario.h"
#include "tests/server/service_fixture.h"
#include "tests/support/sanitizers.h"

namespace oaipp::client {
namespace {

// The real server in-process, with two planning threads, and a client over
// its channel.
struct LocalService {
  server::testing::InProcessService server{
      server::ServerParts{.planning_threads = 2, .planning_queue = 8}};
  server::MissionRegistry& registry = server.registry();
  Client client{server.channel(), {}};
};

using ::oaipp::testing::UnlessSanitized;

// E1 with a 30 s budget and 10 CMA-ES generations a plan (one under the
// sanitizers, where what is checked is the flight, not the search): a short
// mission.
absl::StatusOr<v1::Scenario> ShortE1Scenario() {
  absl::StatusOr<v1::Scenario> scenario = sim::LoadScenarioFile(OAIPP_SCENARIO_DIR "/e1.json");
  if (!scenario.ok()) return scenario;
  scenario->mutable_mission()->set_budget_s(30);
  scenario->mutable_mission()->mutable_planner()->set_generations(UnlessSanitized(10));
  return scenario;
}

TEST(EndToEndTest, ShortE1MissionReducesErrorWithoutCollisions) {
  LocalService local;
  Client& client = local.client;
  auto scenario = ShortE1Scenario();
  ASSERT_TRUE(scenario.ok()) << scenario.status();
  auto simulation = sim::Simulation::Create(*scenario);
  ASSERT_TRUE(simulation.ok());
  auto result = RunScenario(client, *scenario, *simulation);
  ASSERT_TRUE(result.ok()) << result.status();
  ASSERT_GE(result->steps.size(), 4u);  // the start + 30 s at 0.15 Hz
  EXPECT_LT(result->steps.back().rse, result->steps.front().rse);
  EXPECT_EQ(result->steps.back().collisions, 0);
  EXPECT_NEAR(result->steps.back().mission_time_s, 30.0, 1e-6);
  EXPECT_GT(result->steps.back().path_length_m, 10.0);
  EXPECT_EQ(result->final_map_png.substr(1, 3), "PNG");
  // The per-shot log holds every sighting the counts hold, in flight order,
  // with the mean read back after that shot.
  ASSERT_EQ(result->sightings.size(), 7u);
  std::vector<int> in_view(7, 0), detected(7, 0);
  double last_t = 0.0;
  for (const SightingRecord& r : result->sighting_log) {
    ASSERT_GE(r.target, 0);
    ASSERT_LT(r.target, 7);
    ++in_view[static_cast<std::size_t>(r.target)];
    detected[static_cast<std::size_t>(r.target)] += r.detected ? 1 : 0;
    EXPECT_GE(r.mission_time_s, last_t);
    EXPECT_LE(r.mission_time_s, 30.0 + 1e-6);
    last_t = r.mission_time_s;
    EXPECT_TRUE(std::isfinite(r.mean_after));
  }
  for (std::size_t i = 0; i < 7; ++i) {
    EXPECT_EQ(in_view[i], result->sightings[i].in_view) << i;
    EXPECT_EQ(detected[i], result->sightings[i].detected) << i;
  }
  EXPECT_FALSE(result->sighting_log.empty());
  EXPECT_EQ(local.registry.size(), 0u);  // the mission was deleted afterwards
}

// With replan_on_detection and a detector that reports something in every
// image, each shot that another can follow ends its path there: the client
// replans from the moving state, the server answers every one, and the
// flight stays clear. Without it the same mission replans only at the ends
// of paths.
TEST(EndToEndTest, ReplanOnDetectionReplansAfterEveryShotWithAReport) {
  LocalService local;
  Client& client = local.client;
  auto scenario = ShortE1Scenario();
  ASSERT_TRUE(scenario.ok()) << scenario.status();
  // 100 false positives an image at 10 m (the most a scenario may ask for),
  // 25 at 5 m: an image without a report is all but impossible at the
  // altitudes these paths fly.
  scenario->mutable_detector()->set_fp_per_image_at_10m(100);
  auto simulation = sim::Simulation::Create(*scenario);
  ASSERT_TRUE(simulation.ok());
  auto at_ends = RunScenario(client, *scenario, *simulation);
  ASSERT_TRUE(at_ends.ok()) << at_ends.status();
  scenario->set_replan_on_detection(true);
  auto on_detection = RunScenario(client, *scenario, *simulation);
  ASSERT_TRUE(on_detection.ok()) << on_detection.status();

  // Shots at 0, 6.7, 13.3, 20 and 26.7 s (0.15 Hz): five records after the
  // start's, and one at the budget's end.
  for (const RunResult* r : {&*at_ends, &*on_detection}) {
    ASSERT_EQ(r->steps.size(), 7u);
    EXPECT_EQ(r->steps[1].mission_time_s, 0.0);
    EXPECT_NEAR(r->steps[5].mission_time_s, 80.0 / 3.0, 1e-6);
    EXPECT_NEAR(r->steps.back().mission_time_s, 30.0, 1e-6);
    EXPECT_EQ(r->steps.back().collisions, 0);
  }
  // Every shot but the last ends its path: after it no shot fits in the
  // budget (the next would be at 33.3 s). Each cut is followed by a plan.
  EXPECT_EQ(on_detection->paths_cut, 4);
  EXPECT_GE(on_detection->plans, 1 + 4);
  EXPECT_EQ(at_ends->paths_cut, 0);
  EXPECT_LT(at_ends->plans, on_detection->plans);
  EXPECT_EQ(local.registry.size(), 0u);
}

// e5-team4.json's first three UAVs for 30 s, 10 CMA-ES generations a plan.
absl::StatusOr<v1::Scenario> ShortTeamScenario() {
  absl::StatusOr<v1::Scenario> scenario =
      sim::LoadScenarioFile(OAIPP_SCENARIO_DIR "/e5-team4.json");
  if (!scenario.ok()) return scenario;
  scenario->mutable_mission()->set_budget_s(30);
  scenario->mutable_mission()->mutable_planner()->set_generations(10);
  scenario->mutable_mission()->mutable_team()->RemoveLast();
  return scenario;
}

// A team of three in E5's world for 30 s: every UAV plans under its uav_id
// and takes its shots at 0, 6.7, 13.3, 20 and 26.7 s, every shot lands in
// the one map, no two UAVs come closer than min_separation_m at any 20 ms
// step (by the runner's distance code, not the server's), nothing collides,
// and the same seed flies the same mission again.
TEST(EndToEndTest, ATeamFliesOneMapApartAndTheSameSeedFliesItAgain) {
  LocalService local;
  auto scenario = ShortTeamScenario();
  ASSERT_TRUE(scenario.ok()) << scenario.status();
  auto simulation = sim::Simulation::Create(*scenario);
  ASSERT_TRUE(simulation.ok()) << simulation.status();
  auto first = RunScenario(local.client, *scenario, *simulation, nullptr, /*keep_mission=*/true);
  ASSERT_TRUE(first.ok()) << first.status();

  ASSERT_EQ(first->uavs.size(), 3u);
  int shots = 0;
  for (std::size_t i = 0; i < 3; ++i) {
    const UavRecord& u = first->uavs[i];
    EXPECT_EQ(u.uav_id, scenario->mission().team(static_cast<int>(i)).uav_id());
    EXPECT_GE(u.plans, 1) << u.uav_id;
    EXPECT_EQ(u.shots, 5) << u.uav_id;
    EXPECT_EQ(u.collisions, 0) << u.uav_id;
    EXPECT_GT(u.path_length_m, 5.0) << u.uav_id;
    shots += u.shots;
  }
  EXPECT_EQ(first->separation_violations, 0);
  EXPECT_GE(first->closest_approach_m, 4.0 - 1e-6);  // e5-team4's default min_separation_m
  EXPECT_LT(first->closest_approach_m, 30.0);        // measured, not left at infinity
  // A record per shot, each naming its UAV, and the map fused them all.
  ASSERT_EQ(first->steps.size(), static_cast<std::size_t>(1 + shots + 1));
  for (std::size_t k = 1; k + 1 < first->steps.size(); ++k) {
    EXPECT_THAT(first->steps[k].uav_id, ::testing::StartsWith("uav-")) << k;
  }
  EXPECT_LT(first->steps.back().rse, first->steps.front().rse);
  absl::StatusOr<v1::Mission> mission = local.client.GetMission(first->mission_name);
  ASSERT_TRUE(mission.ok()) << mission.status();
  EXPECT_EQ(mission->measurements_fused(), shots);
  EXPECT_EQ(mission->paths_planned(), first->plans);

  auto again = RunScenario(local.client, *scenario, *simulation);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(StepsCsv(again->steps), StepsCsv(first->steps));
  EXPECT_EQ(again->closest_approach_m, first->closest_approach_m);
}

// E7's baseline: the same team with separate maps flies a single-UAV
// mission per member, each from that member's start, fusing and planning
// on its own shots only; one more mission, which nobody plans for, fuses
// every member's shots, and the records are that map's.
TEST(EndToEndTest, ATeamOnSeparateMapsFliesAMissionPerUavThatKnowsNoTeammate) {
  LocalService local;
  auto scenario = ShortTeamScenario();
  ASSERT_TRUE(scenario.ok()) << scenario.status();
  scenario->set_separate_maps(true);
  auto simulation = sim::Simulation::Create(*scenario);
  ASSERT_TRUE(simulation.ok()) << simulation.status();
  auto run = RunScenario(local.client, *scenario, *simulation, nullptr, /*keep_mission=*/true);
  ASSERT_TRUE(run.ok()) << run.status();

  ASSERT_EQ(run->uavs.size(), 3u);
  EXPECT_EQ(local.registry.size(), 4u);
  std::set<std::string> missions = {run->mission_name};
  for (std::size_t i = 0; i < 3; ++i) {
    const UavRecord& u = run->uavs[i];
    missions.insert(u.mission);
    EXPECT_EQ(u.shots, 5) << u.uav_id;
    absl::StatusOr<v1::Mission> m = local.client.GetMission(u.mission);
    ASSERT_TRUE(m.ok()) << m.status();
    EXPECT_EQ(m->spec().team_size(), 0) << u.uav_id;
    EXPECT_EQ(m->measurements_fused(), 5) << u.uav_id;
    EXPECT_EQ(m->paths_planned(), u.plans) << u.uav_id;
    const v1::Vector3& start = scenario->mission().team(static_cast<int>(i)).start().position_m();
    EXPECT_EQ(m->spec().start().position_m().x(), start.x()) << u.uav_id;
    EXPECT_EQ(m->spec().start().position_m().y(), start.y()) << u.uav_id;
  }
  EXPECT_EQ(missions.size(), 4u);
  absl::StatusOr<v1::Mission> all = local.client.GetMission(run->mission_name);
  ASSERT_TRUE(all.ok()) << all.status();
  EXPECT_EQ(all->measurements_fused(), 15);
  EXPECT_EQ(all->paths_planned(), 0);
  absl::StatusOr<v1::GetMapResponse> map = local.client.GetMap(run->mission_name, true, false);
  ASSERT_TRUE(map.ok()) << map.status();
  const std::vector<double> mean(map->mean().begin(), map->mean().end());
  EXPECT_EQ(run->steps.back().trace, map->trace());
  EXPECT_EQ(run->steps.back().targets_found, simulation->TargetsFound(mean));
  EXPECT_LT(run->closest_approach_m, 30.0);  // measured, though nobody kept them apart

  auto again = RunScenario(local.client, *scenario, *simulation);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(StepsCsv(again->steps), StepsCsv(run->steps));
  EXPECT_EQ(local.registry.size(), 4u);  // the second run's four are gone
}

// Take-off pacing: with the server's one take-off slot held, the client's
// take-off plan is refused with a retry delay; the client waits as told and
// asks again (not a failed attempt), and gets its path once the slot is free.
TEST(EndToEndTest, APacedTakeOffWaitsAndThenFlies) {
  server::testing::InProcessService local(server::ServerParts{
      .service = {.max_take_off_plans = 1}, .planning_threads = 1, .planning_queue = 8});
  server::PlanningPool& planners = local.planners();
  Client first(local.channel(), {});
  Client second(local.channel(), {});

  auto scenario = sim::LoadScenarioFile(OAIPP_SCENARIO_DIR "/e1.json");
  ASSERT_TRUE(scenario.ok()) << scenario.status();
  v1::MissionSpec spec = scenario->mission();
  spec.mutable_planner()->set_generations(2);
  absl::StatusOr<v1::Mission> created = first.CreateMission(spec, "first");
  ASSERT_TRUE(created.ok()) << created.status();
  ASSERT_TRUE(second.CreateMission(spec, "second").ok());
  auto take_off = [&](Client& client, const std::string& id) {
    v1::PlanPathRequest request;
    request.set_name("missions/" + id);
    *request.mutable_state() = created->spec().start();  // at rest, mission time 0
    return client.PlanPath(request);
  };
  // Polls `done` for up to 10 s.
  auto eventually = [](auto done) {
    for (int i = 0; i < 1000 && !done(); ++i) absl::SleepFor(absl::Milliseconds(10));
    return done();
  };
  absl::Notification release;
  ASSERT_TRUE(planners.Submit("blocker", [&] { release.WaitForNotification(); }).ok());
  const bool held = eventually([&] { return planners.running() == 1; });
  absl::StatusOr<v1::PlanPathResponse> a, b;
  std::thread one([&] { a = take_off(first, "first"); });
  const bool queued = held && eventually([&] { return planners.waiting() == 1; });
  // A client that will not wait gets the refusal itself.
  ClientOptions impatient_options;
  impatient_options.max_retry_after = absl::ZeroDuration();
  Client impatient(local.channel(), impatient_options);
  const absl::StatusOr<v1::PlanPathResponse> refused = take_off(impatient, "second");
  std::thread two([&] { b = take_off(second, "second"); });
  const bool paced = eventually([&] { return second.paced_calls() >= 1; });
  release.Notify();
  one.join();
  two.join();
  ASSERT_TRUE(held);
  ASSERT_TRUE(queued);
  EXPECT_TRUE(paced);
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kResourceExhausted) << refused.status();
  EXPECT_EQ(impatient.paced_calls(), 0);
  ASSERT_TRUE(a.ok()) << a.status();
  ASSERT_TRUE(b.ok()) << b.status();
  EXPECT_GT(b->trajectory().segments_size(), 0);
  EXPECT_EQ(first.paced_calls(), 0);
  EXPECT_GE(second.paced_calls(), 1);
  EXPECT_EQ(second.retried_calls(), 0);
}

}  // namespace
}  // namespace oaipp::client
