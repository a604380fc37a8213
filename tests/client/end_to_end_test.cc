// A short mission end to end: the real service in-process, the client over
// its channel, the E1 world with a 30 s budget. RSE must fall; no collision.
#include "client/cli/mission_runner.h"
#include "gtest/gtest.h"
#include "server/service.h"
#include "sim/scenario.h"

namespace oaipp::client {
namespace {

TEST(EndToEndTest, ShortE1MissionReducesErrorWithoutCollisions) {
  server::MissionRegistry registry({});
  server::PlanningPool planners(2, 8);
  server::MissionServiceImpl service(&registry, &planners, nullptr);
  grpc::ServerBuilder builder;
  builder.RegisterService(&service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  Client client(server->InProcessChannel(grpc::ChannelArguments()), {});

  auto scenario = sim::LoadScenarioFile(OAIPP_SCENARIO_DIR "/e1.json");
  ASSERT_TRUE(scenario.ok()) << scenario.status();
  scenario->mutable_mission()->set_budget_s(30);
  scenario->mutable_mission()->mutable_planner()->set_generations(10);
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
  EXPECT_EQ(registry.size(), 0u);  // the mission was deleted afterwards
  server->Shutdown();
}

}  // namespace
}  // namespace oaipp::client
