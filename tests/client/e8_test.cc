// E8's pieces (client/cli/e8.h): the mission a SAREnv crop becomes, a short
// flight through the real service stopped by its path budget and scored in
// the crop's CRS, and the summary's paired statistics against numbers
// worked out by hand.
#include "client/cli/e8.h"

#include <cmath>
#include <string>
#include <vector>

#include "client/sarenv/dataset.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "server/service.h"
#include "sim/simulation.h"
#include "tests/server/service_fixture.h"
#include "tests/support/sanitizers.h"

namespace oaipp::client {
namespace {

using ::testing::HasSubstr;

sarenv::SearchArea Crop() {
  absl::StatusOr<sarenv::SearchArea> area =
      sarenv::ReadSearchArea(OAIPP_SARENV_TEST_DATA "/dataset1_medium.npy",
                             OAIPP_SARENV_TEST_DATA "/dataset1_medium.json");
  EXPECT_TRUE(area.ok()) << area.status();
  return area.ok() ? *area : sarenv::SearchArea{};
}

TEST(E8ScenarioTest, TheMissionsFieldIsTheCropsGridAndItsPriorTheCropsMap) {
  const sarenv::SearchArea area = Crop();
  ASSERT_EQ(area.heatmap.rows, 120);
  absl::StatusOr<v1::Scenario> s = E8Scenario(area, 2, 20000, {});
  ASSERT_TRUE(s.ok()) << s.status();
  const v1::MissionSpec& m = s->mission();
  // The crop spans 3600 m in 120 cells around its centre (the JSON's
  // numbers), so the field is [-1800, 1800]^2 at 30 m.
  EXPECT_DOUBLE_EQ(m.field().resolution_m(), 30.0);
  EXPECT_DOUBLE_EQ(m.field().x_min_m(), -1800.0);
  EXPECT_DOUBLE_EQ(m.field().y_max_m(), 1800.0);
  EXPECT_EQ(m.field().map_backend(), v1::MAP_BACKEND_SPARSE);
  ASSERT_EQ(m.gp().prior_map().values_size(), 120 * 120);
  for (int i = 0; i < 120 * 120; ++i) {
    ASSERT_EQ(m.gp().prior_map().values(i), area.heatmap.values[static_cast<std::size_t>(i)]);
  }
  EXPECT_EQ(m.gp().prior_map().units(), v1::PRIOR_MAP_UNITS_PROBABILITY);
  EXPECT_EQ(m.planner().kind(), v1::PLANNER_KIND_OAIPP_DETECTION);
  EXPECT_NEAR(m.planner().detection_discount(), std::pow(0.999, 60.0), 1e-15);
  EXPECT_DOUBLE_EQ(m.sensor().fov_x_deg(), 45.0);
  EXPECT_DOUBLE_EQ(m.sensor().rate_hz(), 15.0 / 60.0);
  // Two UAVs 10 m apart about the last known point, at 80 m, each flying
  // 2 % past half the budget.
  ASSERT_EQ(m.team_size(), 2);
  EXPECT_DOUBLE_EQ(m.team(0).start().position_m().x(), -5.0);
  EXPECT_DOUBLE_EQ(m.team(1).start().position_m().x(), 5.0);
  EXPECT_DOUBLE_EQ(m.team(1).start().position_m().z(), 80.0);
  EXPECT_DOUBLE_EQ(s->path_budget_m(), 10200.0);
  EXPECT_TRUE(s->final_map_only());

  EXPECT_THAT(E8Scenario(area, 0, 20000, {}).status().message(), HasSubstr("agents"));
  EXPECT_THAT(E8Scenario(area, 17, 20000, {}).status().message(), HasSubstr("agents"));
  EXPECT_THAT(E8Scenario(area, 1, -1, {}).status().message(), HasSubstr("budget_m"));
  sarenv::SearchArea lopsided = area;
  lopsided.bounds.max_x_m += 30.0;
  EXPECT_THAT(E8Scenario(lopsided, 1, 1000, {}).status().message(), HasSubstr("square"));
}

// A short flight through the real service: the UAV stops at the end of the
// path on which it passed its path budget, long before the time budget,
// and its path, moved into the CRS, starts at the crop's centre.
TEST(E8Test, AShortFlightStopsAtItsPathBudgetAndIsScoredInTheCrs) {
  server::testing::InProcessService service{
      server::ServerParts{.planning_threads = 2, .planning_queue = 8}};
  Client client{service.channel(), {}};
  const sarenv::SearchArea area = Crop();
  absl::StatusOr<v1::Scenario> s = E8Scenario(area, 1, 800, {});
  ASSERT_TRUE(s.ok()) << s.status();
  s->mutable_mission()->mutable_planner()->set_generations(testing::UnlessSanitized(10));
  absl::StatusOr<sim::Simulation> sim = sim::Simulation::Create(*s);
  ASSERT_TRUE(sim.ok()) << sim.status();
  absl::StatusOr<RunResult> run = RunScenario(client, *s, *sim);
  ASSERT_TRUE(run.ok()) << run.status();
  ASSERT_EQ(run->uavs.size(), 1u);
  EXPECT_GE(run->uavs[0].path_length_m, 816.0);  // 2 % past the share
  EXPECT_LT(run->steps.back().mission_time_s, s->mission().budget_s());
  // Only the start and the end were read (final_map_only).
  EXPECT_EQ(run->steps.size(), 2u);
  const std::vector<sarenv::Polyline> paths = FlownPathsInCrs(*run, area);
  ASSERT_EQ(paths.size(), 1u);
  ASSERT_FALSE(paths[0].empty());
  EXPECT_NEAR(paths[0].front().x_m, area.center_x_m, 1e-6);
  EXPECT_NEAR(paths[0].front().y_m, area.center_y_m, 1e-6);
  EXPECT_NEAR(sarenv::PolylineLength_m(paths[0]), run->uavs[0].path_length_m, 1.0);
  absl::StatusOr<sarenv::PathMetrics> m =
      sarenv::EvaluatePaths(area, sarenv::CutToBudget(paths, 800), {});
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_NEAR(m->total_path_length_km, 0.8, 1e-9);
  EXPECT_GT(m->likelihood, 0.0);
}

// The flown path moves into the CRS by the crop's centre, and a point lands
// in the same cell of the mission's field (the prior's index) as of the
// evaluator's grid (the crop's bounds over its shape).
TEST(E8Test, FlownPathsMoveIntoTheCrsOntoTheSameCells) {
  const sarenv::SearchArea area = Crop();
  RunResult run;
  run.uavs.resize(2);
  run.uavs[0].flown_path_W = {Vec3(0, 0, 80), Vec3(100, -200, 80)};
  run.uavs[1].flown_path_W = {Vec3(-1234.5, 987.25, 79)};
  const std::vector<sarenv::Polyline> paths = FlownPathsInCrs(run, area);
  ASSERT_EQ(paths.size(), 2u);
  ASSERT_EQ(paths[0].size(), 2u);
  EXPECT_DOUBLE_EQ(paths[0][1].x_m, area.center_x_m + 100);
  EXPECT_DOUBLE_EQ(paths[0][1].y_m, area.center_y_m - 200);
  EXPECT_DOUBLE_EQ(paths[1][0].x_m, area.center_x_m - 1234.5);
  absl::StatusOr<v1::Scenario> s = E8Scenario(area, 1, 1000, {});
  ASSERT_TRUE(s.ok());
  const v1::FieldSpec& f = s->mission().field();
  for (const auto& [local, crs] : {std::pair{Vec3(100, -200, 0), paths[0][1]},
                                   std::pair{Vec3(-1234.5, 987.25, 0), paths[1][0]}}) {
    const int col = static_cast<int>((local.x() - f.x_min_m()) / f.resolution_m());
    const int row = static_cast<int>((local.y() - f.y_min_m()) / f.resolution_m());
    const auto crs_col = static_cast<int64_t>((crs.x_m - area.bounds.min_x_m) / area.CellSizeX_m());
    const auto crs_row = static_cast<int64_t>((crs.y_m - area.bounds.min_y_m) / area.CellSizeY_m());
    EXPECT_EQ(col, crs_col);
    EXPECT_EQ(row, crs_row);
    EXPECT_EQ(s->mission().gp().prior_map().values(row * 120 + col),
              area.heatmap.At(crs_row, crs_col));
  }
}

E8Row Row(const std::string& dataset, const std::string& algorithm, double likelihood, double td,
          double victims) {
  E8Row r;
  r.dataset = dataset;
  r.algorithm = algorithm;
  r.agents = 1;
  r.budget_m = 20000;
  r.metrics.likelihood = likelihood;
  r.metrics.time_discounted = td;
  r.metrics.victims_found_pct = victims;
  return r;
}

// OA-IPP minus Greedy in time-discounted score, per dataset: 2, 3, 4: mean
// 3, standard deviation 1, standard error 1 / sqrt(3), 5.196 standard
// errors. Minus Spiral in likelihood: 0.1, -0.1, 0.3: mean 0.1, sd 0.2,
// se 0.11547, 0.866 standard errors. Victims: 10 against Greedy's 20.
TEST(E8SummaryTest, PairedDifferencesAndTargetsAsWorkedOutByHand) {
  const std::vector<E8Row> rows = {
      Row("1", "OA-IPP", 0.5, 3, 10), Row("2", "OA-IPP", 0.4, 5, 10),
      Row("3", "OA-IPP", 0.6, 7, 10), Row("1", "Greedy", 0.1, 1, 20),
      Row("2", "Greedy", 0.1, 2, 20), Row("3", "Greedy", 0.1, 3, 20),
      Row("1", "Spiral", 0.4, 0, 5),  Row("2", "Spiral", 0.5, 0, 5),
      Row("3", "Spiral", 0.3, 0, 5),
  };
  const std::string md = E8SummaryMarkdown(rows);
  EXPECT_THAT(md, HasSubstr("### n = 1, 20 km in all"));
  // Greedy's row: likelihood +0.4000 (se 0.0577, +6.9), td +3 (se 0.57735).
  EXPECT_THAT(md, HasSubstr("| Greedy | +0.4000 (0.0577, +6.9) | +3.00000 (0.57735, +5.2) |"));
  EXPECT_THAT(md, HasSubstr("time-discounted above Greedy by 5.2 SE (> 2: met)"));
  EXPECT_THAT(md, HasSubstr("likelihood above Spiral by 0.9 SE (> 2: not met)"));
  EXPECT_THAT(md, HasSubstr("victims found 10.0 % against Greedy's 20.0 % (not met)"));
  // OA-IPP's means +- 1.96 standard errors: likelihood 0.5 +- 1.96 * 0.0577.
  EXPECT_THAT(md, HasSubstr("| OA-IPP | 3 | 0.5000 +- 0.1132 | 5.00000 +- 2.26321 |"));
  // One dataset has no spread to measure a difference by; a flight short
  // of its budget is counted.
  std::vector<E8Row> one = {Row("1", "OA-IPP", 0.5, 3, 10), Row("1", "Greedy", 0.1, 1, 20)};
  one[0].short_of_budget = true;
  const std::string single = E8SummaryMarkdown(one);
  EXPECT_THAT(single, HasSubstr("| Greedy | n/a | n/a | n/a | n/a |"));
  EXPECT_THAT(single, HasSubstr("time-discounted above Greedy: n/a; likelihood above Spiral: n/a"));
  EXPECT_THAT(single, HasSubstr("1 OA-IPP flight(s) ended short of the budget."));
  const std::string csv = E8Csv(rows);
  EXPECT_THAT(csv, HasSubstr("\n1,OA-IPP,1,20000,0.5,3,10,0,0,0,0.000,0.000\n"));
}

}  // namespace
}  // namespace oaipp::client
