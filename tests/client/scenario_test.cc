#include "client/scenario.h"

#include "client/simulation.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace oaipp::client {
namespace {

using ::testing::HasSubstr;

TEST(ScenarioTest, TheE1FileParsesIntoThePapersWorld) {
  auto scenario = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e1.json");
  ASSERT_TRUE(scenario.ok()) << scenario.status();
  EXPECT_EQ(scenario->name(), "e1");
  EXPECT_EQ(scenario->targets_size(), 7);
  auto sim = Simulation::Create(*scenario);
  ASSERT_TRUE(sim.ok()) << sim.status();
  EXPECT_EQ(sim->num_targets(), 7);
  EXPECT_DOUBLE_EQ(sim->config().budget_s, 150.0);
  // REFERENCE.md: the E1 people cover 48 cells; RSE0 = 7.375636 at prior 0.1.
  EXPECT_NEAR(sim->Rse(std::vector<double>(1600, 0.1)), 7.375636, 1e-6);
}

TEST(ScenarioTest, MalformedJsonNamesTheLine) {
  const auto s = ParseScenario("{\n  \"name\": \"x\",\n  \"seed\": ,\n}\n", "bad.json");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.status().message(), HasSubstr("bad.json:3:"));
}

TEST(ScenarioTest, SchemaErrorsNameTheField) {
  auto unknown = ParseScenario(R"({"name": "x", "bogus": 1})", "s.json");
  ASSERT_FALSE(unknown.ok());
  EXPECT_THAT(unknown.status().message(), HasSubstr("bogus"));
  auto wrong_type = ParseScenario(R"({"targets": [{"x_min_m": "abc"}]})", "s.json");
  ASSERT_FALSE(wrong_type.ok());
  EXPECT_THAT(wrong_type.status().message(), HasSubstr("targets[0].x_min_m"));
}

TEST(ScenarioTest, BadContentNamesTheField) {
  auto s = ParseScenario(
      R"({"targets": [{"x_min_m": 2, "x_max_m": 1, "y_min_m": 0, "y_max_m": 1}]})", "s.json");
  ASSERT_TRUE(s.ok());
  EXPECT_THAT(Simulation::Create(*s).status().message(), HasSubstr("targets[0]"));
  s = ParseScenario(R"({"detector": {"p_max": 1.5}})", "s.json");
  ASSERT_TRUE(s.ok());
  EXPECT_THAT(Simulation::Create(*s).status().message(), HasSubstr("detector.p_max"));
  s = ParseScenario(R"({"mission": {"field": {"resolution_m": -1}}})", "s.json");
  ASSERT_TRUE(s.ok());
  EXPECT_THAT(Simulation::Create(*s).status().message(), HasSubstr("resolution_m"));
  EXPECT_EQ(LoadScenarioFile("/nonexistent.json").status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace oaipp::client
