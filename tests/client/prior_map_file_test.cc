// Scenario.prior_map_file: the client reads a lost-person map from a .npy
// file into the mission's prior map, refuses what does not fit the field
// naming the field, and a short mission flies on it against the real service.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <numeric>

#include "client/cli/mission_runner.h"
#include "client/cli/prior_map_file.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "sim/scenario.h"
#include "tests/server/service_fixture.h"
#include "tests/support/sanitizers.h"

namespace oaipp::client {
namespace {

using cli::ReadPriorMapFile;
using ::testing::HasSubstr;

constexpr char kDemo[] = OAIPP_SCENARIO_DIR "/prior-demo.json";

v1::Scenario Demo() {
  absl::StatusOr<v1::Scenario> scenario = sim::LoadScenarioFile(kDemo);
  EXPECT_TRUE(scenario.ok()) << scenario.status();
  return *scenario;
}

TEST(PriorMapFileTest, TheDemosMapBecomesTheMissionsPriorMap) {
  v1::Scenario scenario = Demo();
  const double scale = scenario.prior_map_file().scale();
  ASSERT_TRUE(ReadPriorMapFile(scenario, kDemo).ok());
  EXPECT_FALSE(scenario.has_prior_map_file());
  const v1::PriorMap& map = scenario.mission().gp().prior_map();
  ASSERT_EQ(map.values_size(), 40 * 40);
  EXPECT_EQ(map.units(), v1::PRIOR_MAP_UNITS_LABEL_MEAN);
  // NumPy's numbers for the file (make_prior_demo.py): the SAREnv crop's
  // mass, 0.28074492558593855, and a peak scaled to 0.5.
  const double sum = std::accumulate(map.values().begin(), map.values().end(), 0.0);
  EXPECT_NEAR(sum / scale, 0.28074492558593855, 1e-12);
  EXPECT_NEAR(*std::max_element(map.values().begin(), map.values().end()), 0.5, 1e-12);

  // With the first row north, the rows come in the other order.
  v1::Scenario flipped = Demo();
  flipped.mutable_prior_map_file()->set_first_row_north(true);
  ASSERT_TRUE(ReadPriorMapFile(flipped, kDemo).ok());
  const v1::PriorMap& other = flipped.mission().gp().prior_map();
  for (int row = 0; row < 40; ++row) {
    for (int col = 0; col < 40; ++col) {
      ASSERT_EQ(other.values(row * 40 + col), map.values((39 - row) * 40 + col));
    }
  }
}

TEST(PriorMapFileTest, AMapThatDoesNotFitIsRefusedNamingTheField) {
  v1::Scenario wrong_shape = Demo();
  wrong_shape.mutable_mission()->mutable_field()->set_resolution_m(1.0);  // 30 x 30 cells
  absl::Status status = ReadPriorMapFile(wrong_shape, kDemo);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(status.message(), HasSubstr("prior_map_file.path: "));
  EXPECT_THAT(status.message(), HasSubstr("holds 40 x 40 values; the field has 30 rows x 30"));

  v1::Scenario zero_scale = Demo();
  zero_scale.mutable_prior_map_file()->set_scale(0);
  EXPECT_THAT(ReadPriorMapFile(zero_scale, kDemo).message(),
              HasSubstr("prior_map_file.scale: must be > 0"));

  v1::Scenario both = Demo();
  both.mutable_mission()->mutable_gp()->set_prior_mean(0.2);
  EXPECT_THAT(ReadPriorMapFile(both, kDemo).message(),
              HasSubstr("prior_map_file: not with mission.gp.prior_mean"));

  v1::Scenario missing = Demo();
  missing.mutable_prior_map_file()->set_path("no-such-map.npy");
  EXPECT_EQ(ReadPriorMapFile(missing, kDemo).code(), absl::StatusCode::kNotFound);

  // A file that is not a 2-D float64 array.
  const std::filesystem::path bad =
      std::filesystem::temp_directory_path() / "oaipp-prior-map-file-test.npy";
  std::ofstream(bad) << "not numpy";
  v1::Scenario garbage = Demo();
  garbage.mutable_prior_map_file()->set_path(bad.string());
  EXPECT_EQ(ReadPriorMapFile(garbage, kDemo).code(), absl::StatusCode::kInvalidArgument);
  std::filesystem::remove(bad);
}

// A short flight of the demo (30 s, 10 CMA-ES generations a plan, one under
// the sanitizers): the service takes the map and the mission flies without a
// collision.
TEST(PriorMapFileTest, TheDemoFliesOnItsPrior) {
  server::testing::InProcessService service(
      server::ServerParts{.planning_threads = 2, .planning_queue = 8});
  Client client{service.channel(), {}};
  v1::Scenario scenario = Demo();
  ASSERT_TRUE(ReadPriorMapFile(scenario, kDemo).ok());
  scenario.mutable_mission()->set_budget_s(30);
  scenario.mutable_mission()->mutable_planner()->set_generations(
      ::oaipp::testing::UnlessSanitized(10));
  absl::StatusOr<sim::Simulation> simulation = sim::Simulation::Create(scenario);
  ASSERT_TRUE(simulation.ok()) << simulation.status();
  absl::StatusOr<RunResult> run = RunScenario(client, scenario, *simulation);
  ASSERT_TRUE(run.ok()) << run.status();
  ASSERT_GE(run->steps.size(), 4u);
  EXPECT_EQ(run->steps.back().collisions, 0);
  EXPECT_GT(run->steps.back().path_length_m, 10.0);
}

}  // namespace
}  // namespace oaipp::client
