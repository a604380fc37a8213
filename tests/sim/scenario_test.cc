#include "sim/scenario.h"

#include <cmath>
#include <filesystem>
#include <string>

#include "absl/strings/str_cat.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "sim/simulation.h"
#include "tests/support/sanitizers.h"

namespace oaipp::sim {
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
  // docs/reference-values.md: the E1 people cover 48 cells; RSE0 = 7.375636 at prior 0.1.
  EXPECT_NEAR(sim->Rse(std::vector<double>(1600, 0.1)), 7.375636, 1e-6);
}

TEST(ScenarioTest, WithDetectorNoiseTellsTheServerTheScenariosDetector) {
  auto scenario = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e1.json");
  ASSERT_TRUE(scenario.ok()) << scenario.status();
  scenario->mutable_mission()->mutable_sensor()->set_noise_a_var(0.5);
  scenario->mutable_detector()->set_p_max(0.9);
  scenario->mutable_detector()->set_width_m(5.0);
  scenario->mutable_detector()->clear_h_best_m();
  const absl::StatusOr<v1::Scenario> with = WithDetectorNoise(*scenario);
  ASSERT_TRUE(with.ok()) << with.status();
  const v1::Scenario& s = *with;
  const v1::SensorSpec& sensor = s.mission().sensor();
  EXPECT_FALSE(sensor.has_noise_a_var());
  EXPECT_FALSE(sensor.has_noise_b_per_m());
  ASSERT_TRUE(sensor.has_detector_noise());
  EXPECT_EQ(sensor.detector_noise().p_max(), 0.9);
  EXPECT_EQ(sensor.detector_noise().h_best_m(), 10.0);  // unset in the scenario: the default
  EXPECT_EQ(sensor.detector_noise().width_m(), 5.0);
  // The rest of the scenario is as it was.
  EXPECT_EQ(s.targets_size(), 7);
  EXPECT_EQ(s.mission().obstacles_size(), scenario->mission().obstacles_size());
  EXPECT_TRUE(Simulation::Create(s).ok());

  EXPECT_FALSE(sensor.detector_noise().has_false_positive_rate());

  // With false positives the mission is also told the detector's rate per
  // cell: the default 0.3 an image at 10 m (FalsePositivesPerCell).
  const absl::StatusOr<v1::Scenario> with_fp = WithDetectorNoise(*scenario, true);
  ASSERT_TRUE(with_fp.ok()) << with_fp.status();
  EXPECT_NEAR(with_fp->mission().sensor().detector_noise().false_positive_rate(),
              0.012936641077651672, 1e-12);
  EXPECT_TRUE(Simulation::Create(*with_fp).ok());
  scenario->mutable_detector()->set_fp_per_image_at_10m(0.0);
  EXPECT_THAT(WithDetectorNoise(*scenario, true).status().message(),
              HasSubstr("detector.fp_per_image_at_10m: a false-positive rate needs it positive"));
  scenario->mutable_detector()->clear_fp_per_image_at_10m();

  // A team flies the one detector: a member's own noise settings give way to
  // it, and a member with a narrower camera sees each image's false
  // positives on less ground, tan(22.5 deg) / tan(15 deg) times as many a
  // cell.
  for (const char* id : {"a", "narrow"}) {
    v1::TeamMember& m = *scenario->mutable_mission()->add_team();
    m.set_uav_id(id);
    m.mutable_start()->mutable_position_m()->set_x(id[0] == 'a' ? -10 : 10);
    m.mutable_start()->mutable_position_m()->set_y(10);
    m.mutable_start()->mutable_position_m()->set_z(10);
  }
  scenario->mutable_mission()->mutable_team(1)->mutable_sensor()->set_fov_x_deg(30);
  scenario->mutable_mission()->mutable_team(1)->mutable_sensor()->set_noise_a_var(3);
  const absl::StatusOr<v1::Scenario> team = WithDetectorNoise(*scenario, true);
  ASSERT_TRUE(team.ok()) << team.status();
  const v1::SensorSpec& narrow = team->mission().team(1).sensor();
  EXPECT_FALSE(narrow.has_noise_a_var());
  EXPECT_EQ(narrow.fov_x_deg(), 30);
  EXPECT_NEAR(narrow.detector_noise().false_positive_rate(),
              0.012936641077651672 * std::tan(22.5 * M_PI / 180) / std::tan(15 * M_PI / 180),
              1e-12);
  EXPECT_FALSE(team->mission().team(0).sensor().has_detector_noise());
  const absl::StatusOr<Simulation> flown = Simulation::Create(*team);
  ASSERT_TRUE(flown.ok()) << flown.status();
  const api::UavKit kit = flown->config().KitOf("narrow");
  ASSERT_TRUE(kit.noise.detector.has_value());
  EXPECT_EQ(kit.noise.detector->p_max, 0.9);
  scenario->mutable_mission()->clear_team();

  // A scenario's detector may be perfect; its noise would be zero.
  scenario->mutable_detector()->set_p_max(1.0);
  EXPECT_THAT(WithDetectorNoise(*scenario).status().message(),
              HasSubstr("detector.p_max: detector noise needs it in (0, 1), got 1"));
}

// zurich.json places the E1-like world on Earth: people and buildings given
// by latitude/longitude land where a local degree length puts them
// (WGS84 radii of curvature: 111178.6 m per degree of latitude and 75489.7 m
// per degree of longitude at 47.4 degrees north; to 0.05 m over 15 m).
TEST(ScenarioTest, GeodeticTargetsAndObstaclesBecomeLocalMetres) {
  auto scenario = LoadScenarioFile(OAIPP_SCENARIO_DIR "/zurich.json");
  ASSERT_TRUE(scenario.ok()) << scenario.status();
  const v1::Target& p1 = scenario->targets(0);
  EXPECT_FALSE(p1.has_centre_geo());
  EXPECT_NEAR(0.5 * (p1.x_min_m() + p1.x_max_m()), (8.545700 - 8.545594) * 75489.7, 0.05);
  EXPECT_NEAR(0.5 * (p1.y_min_m() + p1.y_max_m()), (47.397644 - 47.397742) * 111178.6, 0.05);
  EXPECT_NEAR(p1.x_max_m() - p1.x_min_m(), 0.75, 1e-9);
  EXPECT_NEAR(p1.y_max_m() - p1.y_min_m(), 2.0, 1e-9);
  auto sim = Simulation::Create(*scenario);
  ASSERT_TRUE(sim.ok()) << sim.status();
  EXPECT_EQ(sim->num_targets(), 5);
  const Obstacle& building = sim->config().obstacles[0];
  ASSERT_EQ(building.id, "building");
  const Vec3 c = std::get<Box>(building.shape).centre_W;
  EXPECT_NEAR(c.x(), 0.0, 0.05);
  EXPECT_NEAR(c.y(), (47.397733 - 47.397742) * 111178.6, 0.05);
  EXPECT_NEAR(c.z(), 13.0, 0.01);
}

// Every committed scenario (client/scenarios and its folders) parses and
// builds a world, its name matches its file, and the E5 settings and team
// scenarios differ from e5.json (e6-team4 from e6.json, team4-n5 and
// team4-launch from e5-team4.json, team4-launch-confirm and -sep1 from
// team4-launch, team4-launch-preposterior from team4-launch-confirm,
// team4-launch-sigma35 from team4-launch-preposterior) only in what their
// name says.
TEST(ScenarioTest, EveryCommittedScenarioLoads) {
  int files = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(OAIPP_SCENARIO_DIR)) {
    if (entry.path().extension() != ".json") continue;
    ++files;
    auto scenario = LoadScenarioFile(entry.path().string());
    ASSERT_TRUE(scenario.ok()) << entry.path() << ": " << scenario.status();
    const std::string stem = entry.path().stem().string();
    EXPECT_TRUE(scenario->name() == stem || scenario->name() == "e5-" + stem) << entry.path();
    // Under the sanitizers every file is parsed but only every fourth world
    // built (each builds its ESDF; the release stage builds them all).
    if (::oaipp::testing::kSanitized && files % 4 != 1) continue;
    auto sim = Simulation::Create(*scenario);
    ASSERT_TRUE(sim.ok()) << entry.path() << ": " << sim.status();
    EXPECT_GT(sim->num_targets(), 0) << entry.path();
  }
  EXPECT_EQ(files, 28);
  // e6-team4: E6 with a team of 4 in place of its start.
  auto e6 = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e6.json");
  auto e6_team = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e6-team4.json");
  ASSERT_TRUE(e6.ok() && e6_team.ok());
  EXPECT_EQ(e6_team->mission().team_size(), 4);
  e6_team->set_name(e6->name());
  e6_team->mutable_mission()->clear_team();
  *e6_team->mutable_mission()->mutable_start() = e6->mission().start();
  EXPECT_EQ(e6_team->SerializeAsString(), e6->SerializeAsString());
  auto base = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e5.json");
  auto low = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e5-settings/ceiling12-n4.json");
  ASSERT_TRUE(base.ok() && low.ok());
  EXPECT_EQ(low->mission().flight().max_altitude_m(), 12.0);
  EXPECT_EQ(low->mission().planner().num_waypoints(), 4);
  low->set_name(base->name());
  low->mutable_mission()->clear_flight();
  low->mutable_mission()->mutable_planner()->clear_num_waypoints();
  EXPECT_EQ(low->SerializeAsString(), base->SerializeAsString());
  // e5-teamN: E5 with a team of N in place of its start, starts 4 m apart
  // (the default min_separation_m) or more.
  for (const int n : {2, 4, 8}) {
    const std::string name = "e5-team" + std::to_string(n);
    auto team = LoadScenarioFile(OAIPP_SCENARIO_DIR "/" + name + ".json");
    ASSERT_TRUE(team.ok()) << name << ": " << team.status();
    ASSERT_EQ(team->mission().team_size(), n) << name;
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < i; ++j) {
        const v1::Vector3& a = team->mission().team(i).start().position_m();
        const v1::Vector3& b = team->mission().team(j).start().position_m();
        EXPECT_GE(std::hypot(a.x() - b.x(), a.y() - b.y(), a.z() - b.z()), 4.0) << name;
      }
    }
    team->set_name(base->name());
    team->mutable_mission()->clear_team();
    *team->mutable_mission()->mutable_start() = base->mission().start();
    EXPECT_EQ(team->SerializeAsString(), base->SerializeAsString()) << name;
  }
  // e5-settings/team4-n5: e5-team4 with 5 waypoints.
  auto team4 = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e5-team4.json");
  auto n5 = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e5-settings/team4-n5.json");
  ASSERT_TRUE(team4.ok() && n5.ok());
  EXPECT_EQ(n5->mission().planner().num_waypoints(), 5);
  n5->set_name(team4->name());
  n5->mutable_mission()->mutable_planner()->clear_num_waypoints();
  EXPECT_EQ(n5->SerializeAsString(), team4->SerializeAsString());
  // e5-settings/team4-launch: e5-team4 starting together, on the 5 m square
  // (-12, -12) to (-7, -7) at e5-team4's altitude.
  auto launch = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e5-settings/team4-launch.json");
  auto confirm = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e5-settings/team4-launch-confirm.json");
  ASSERT_TRUE(launch.ok() && confirm.ok());
  ASSERT_EQ(launch->mission().team_size(), 4);
  const double corner[4][2] = {{-12.0, -12.0}, {-7.0, -12.0}, {-12.0, -7.0}, {-7.0, -7.0}};
  for (int i = 0; i < 4; ++i) {
    v1::UavState expected = team4->mission().team(i).start();
    expected.mutable_position_m()->set_x(corner[i][0]);
    expected.mutable_position_m()->set_y(corner[i][1]);
    EXPECT_EQ(launch->mission().team(i).start().SerializeAsString(), expected.SerializeAsString())
        << i;
  }
  auto launch_as_team4 = *launch;  // its starts put back, for the comparison at the end
  launch_as_team4.set_name(team4->name());
  for (int i = 0; i < 4; ++i) {
    *launch_as_team4.mutable_mission()->mutable_team(i)->mutable_start() =
        team4->mission().team(i).start();
  }
  EXPECT_EQ(launch_as_team4.SerializeAsString(), team4->SerializeAsString());
  EXPECT_EQ(confirm->mission().planner().confirmation_weight(), 1000.0);
  auto preposterior =
      LoadScenarioFile(OAIPP_SCENARIO_DIR "/e5-settings/team4-launch-preposterior.json");
  ASSERT_TRUE(preposterior.ok());
  EXPECT_TRUE(preposterior->mission().planner().confirmation_preposterior());
  // e5-settings/team4-launch-sigma35: the same with the altitude reward's
  // width halved.
  auto sigma35 = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e5-settings/team4-launch-sigma35.json");
  ASSERT_TRUE(sigma35.ok());
  EXPECT_EQ(sigma35->mission().planner().sigma1_m(), 3.5);
  sigma35->set_name(preposterior->name());
  sigma35->mutable_mission()->mutable_planner()->clear_sigma1_m();
  EXPECT_EQ(sigma35->SerializeAsString(), preposterior->SerializeAsString());
  preposterior->set_name(confirm->name());
  preposterior->mutable_mission()->mutable_planner()->clear_confirmation_preposterior();
  EXPECT_EQ(preposterior->SerializeAsString(), confirm->SerializeAsString());
  confirm->set_name(launch->name());
  confirm->mutable_mission()->mutable_planner()->clear_confirmation_weight();
  EXPECT_EQ(confirm->SerializeAsString(), launch->SerializeAsString());
  auto sep1 = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e5-settings/team4-launch-sep1.json");
  ASSERT_TRUE(sep1.ok());
  EXPECT_EQ(sep1->mission().min_separation_m(), 1.0);
  sep1->set_name(launch->name());
  sep1->mutable_mission()->clear_min_separation_m();
  EXPECT_EQ(sep1->SerializeAsString(), launch->SerializeAsString());
}

TEST(ScenarioTest, MalformedJsonNamesTheLine) {
  const auto s = ParseScenario("{\n  \"name\": \"x\",\n  \"seed\": ,\n}\n", "bad.json");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.status().message(), HasSubstr("bad.json:3:"));
}

// nlohmann reports a number past a double's range as out_of_range, not as a
// parse error; it once escaped (found by fuzz/fuzz_scenario).
TEST(ScenarioTest, ANumberOutOfRangeIsAnErrorNotACrash) {
  const auto s = ParseScenario(R"({"seed": 1e400})", "big.json");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.status().message(), HasSubstr("big.json: a number is out of range"));
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
  // 8.9e81 false positives an image once drew Poisson samples for ever
  // (found by fuzz/fuzz_scenario).
  s = ParseScenario(R"({"detector": {"fp_per_image_at_10m": 8.9e81}})", "s.json");
  ASSERT_TRUE(s.ok());
  EXPECT_THAT(Simulation::Create(*s).status().message(),
              HasSubstr("detector.fp_per_image_at_10m: must be in [0, 100]"));
  s = ParseScenario(R"({"mission": {"field": {"resolution_m": -1}}})", "s.json");
  ASSERT_TRUE(s.ok());
  EXPECT_THAT(Simulation::Create(*s).status().message(), HasSubstr("resolution_m"));
  EXPECT_EQ(LoadScenarioFile("/nonexistent.json").status().code(), absl::StatusCode::kNotFound);
  for (const char* budget : {"0", "-5", "\"Infinity\""}) {
    EXPECT_THAT(ParseScenario(absl::StrCat(R"({"path_budget_m": )", budget, "}"), "s.json")
                    .status()
                    .message(),
                HasSubstr("s.json: path_budget_m: must be > 0 and finite"))
        << budget;
  }
  EXPECT_TRUE(ParseScenario(R"({"path_budget_m": 2000})", "s.json").ok());
}

}  // namespace
}  // namespace oaipp::sim
