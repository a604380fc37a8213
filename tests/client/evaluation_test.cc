#include "client/cli/evaluation.h"

#include <algorithm>

#include "gtest/gtest.h"
#include "sim/scenario.h"

namespace oaipp::client {
namespace {

StepRecord At(double t, double rse) {
  StepRecord r;
  r.mission_time_s = t;
  r.rse = rse;
  return r;
}

// The confirmation variant flies OA-IPP's trial with the confirmation
// weight and, when asked, the phase; the scenario's other settings stay.
TEST(EvaluationTest, ConfirmationVariantSetsTheWeightAndThePhase) {
  auto scenario = sim::LoadScenarioFile(OAIPP_SCENARIO_DIR "/e5.json");
  ASSERT_TRUE(scenario.ok()) << scenario.status();
  const Variant plain = PlannerVariants(*scenario, {PlannerKind::kOaIpp}).front();
  const Variant confirm = ConfirmationVariant(*scenario, {.weight = 100.0, .phase_s = 45.0});
  EXPECT_EQ(confirm.label, "oaipp_confirm");
  auto a = plain.scenario(3);
  auto b = confirm.scenario(3);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(b->mission().planner().confirmation_weight(), 100.0);
  EXPECT_EQ(b->mission().planner().confirmation_phase_s(), 45.0);
  EXPECT_FALSE(a->mission().planner().has_confirmation_phase_s());
  v1::Scenario same = *b;
  same.mutable_mission()->mutable_planner()->clear_confirmation_weight();
  same.mutable_mission()->mutable_planner()->clear_confirmation_phase_s();
  EXPECT_EQ(same.SerializeAsString(), a->SerializeAsString());
  EXPECT_FALSE(ConfirmationVariant(*scenario, {.weight = 100.0})
                   .scenario(3)
                   ->mission()
                   .planner()
                   .has_confirmation_phase_s());
}

// The phase's weight, margin and second look reach the spec only with a
// phase, and only when given.
TEST(EvaluationTest, ConfirmationVariantSetsThePhaseWeightWhenGiven) {
  auto scenario = sim::LoadScenarioFile(OAIPP_SCENARIO_DIR "/e5.json");
  ASSERT_TRUE(scenario.ok()) << scenario.status();
  auto weighted =
      ConfirmationVariant(*scenario, {.weight = 1000.0, .phase_s = 45.0, .phase_weight = 30000.0})
          .scenario(2);
  ASSERT_TRUE(weighted.ok());
  EXPECT_EQ(weighted->mission().planner().confirmation_phase_weight(), 30000.0);
  auto unweighted = ConfirmationVariant(*scenario, {.weight = 1000.0, .phase_s = 45.0}).scenario(2);
  ASSERT_TRUE(unweighted.ok());
  EXPECT_FALSE(unweighted->mission().planner().has_confirmation_phase_weight());
  auto no_phase =
      ConfirmationVariant(*scenario, {.weight = 1000.0, .phase_weight = 30000.0}).scenario(2);
  ASSERT_TRUE(no_phase.ok());
  EXPECT_FALSE(no_phase->mission().planner().has_confirmation_phase_weight());
  EXPECT_FALSE(weighted->mission().planner().has_second_look_weight());
  EXPECT_FALSE(weighted->mission().planner().has_ambiguity_margin());
  auto looking = ConfirmationVariant(*scenario, {.weight = 1000.0,
                                                 .phase_s = 45.0,
                                                 .ambiguity_margin = 0.35,
                                                 .second_look_weight = 1000.0,
                                                 .second_look_sharpness = 0.31})
                     .scenario(2);
  ASSERT_TRUE(looking.ok());
  EXPECT_EQ(looking->mission().planner().second_look_weight(), 1000.0);
  EXPECT_EQ(looking->mission().planner().second_look_sharpness(), 0.31);
  EXPECT_EQ(looking->mission().planner().ambiguity_margin(), 0.35);
  auto no_phase_look = ConfirmationVariant(*scenario, {.weight = 1000.0,
                                                       .ambiguity_margin = 0.35,
                                                       .second_look_weight = 1000.0,
                                                       .second_look_sharpness = 0.31})
                           .scenario(2);
  ASSERT_TRUE(no_phase_look.ok());
  EXPECT_FALSE(no_phase_look->mission().planner().has_second_look_weight());
  EXPECT_FALSE(no_phase_look->mission().planner().has_second_look_sharpness());
  EXPECT_FALSE(no_phase_look->mission().planner().has_ambiguity_margin());
}

std::vector<std::string> Labels(const std::vector<Variant>& variants) {
  std::vector<std::string> labels;
  for (const Variant& v : variants) labels.push_back(v.label);
  return labels;
}

// --variants keeps the named variants in the experiment's order and refuses
// a name the experiment lacks (bounded in the message) or a repeat.
TEST(EvaluationTest, SelectVariantsKeepsTheNamedOnes) {
  auto scenario = sim::LoadScenarioFile(OAIPP_SCENARIO_DIR "/e1.json");
  ASSERT_TRUE(scenario.ok()) << scenario.status();
  auto all = [&] {
    return PlannerVariants(*scenario,
                           {PlannerKind::kOaIpp, PlannerKind::kLawnmower, PlannerKind::kRandom});
  };
  auto every = SelectVariants(all(), {}, "--variants");
  ASSERT_TRUE(every.ok());
  EXPECT_EQ(Labels(*every), (std::vector<std::string>{"oaipp", "lawnmower", "random"}));
  auto two = SelectVariants(all(), {"random", "oaipp"}, "--variants");
  ASSERT_TRUE(two.ok());
  EXPECT_EQ(Labels(*two), (std::vector<std::string>{"oaipp", "random"}));
  auto flown = (*two)[1].scenario(4);
  ASSERT_TRUE(flown.ok());
  EXPECT_EQ(flown->mission().planner().seed(), 4u);

  auto unknown = SelectVariants(all(), {"oaipp", std::string(5000, 'x')}, "--variants");
  EXPECT_EQ(unknown.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(unknown.status().message().rfind("--variants: no variant '", 0), 0u);
  EXPECT_NE(unknown.status().message().find("oaipp, lawnmower, random"), std::string::npos);
  EXPECT_LT(unknown.status().message().size(), 200u);
  auto twice = SelectVariants(all(), {"random", "random"}, "--variants");
  EXPECT_EQ(twice.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(twice.status().message().find("named twice"), std::string::npos);
}

// The grid value at t is the map after every measurement before t: the
// prior at 0 even when a shot is taken at 0, the final map at the budget.
TEST(EvaluationTest, ResampleTakesTheMapBeforeEachGridTime) {
  const std::vector<StepRecord> steps = {At(0, 7.0), At(0, 6.9), At(6.7, 6.5), At(13.3, 6.0),
                                         At(150, 5.0)};
  const std::vector<StepRecord> r = Resample(steps, {0, 5, 10, 15, 150});
  ASSERT_EQ(r.size(), 5u);
  EXPECT_DOUBLE_EQ(r[0].rse, 7.0);
  EXPECT_DOUBLE_EQ(r[1].rse, 6.9);
  EXPECT_DOUBLE_EQ(r[2].rse, 6.5);
  EXPECT_DOUBLE_EQ(r[3].rse, 6.0);
  EXPECT_DOUBLE_EQ(r[4].rse, 6.0);  // the record at 150 is not before 150
  EXPECT_DOUBLE_EQ(r[4].mission_time_s, 150);
}

TEST(EvaluationTest, SummaryReportsMeanStdAndStandardError) {
  EvalResult result;
  result.grid_s = {0, 150};
  for (int k = 0; k < 3; ++k) {
    TrialResult t;
    t.variant = "random";
    t.num_targets = 7;
    t.trial = k + 1;
    t.steps = {At(0, 7.0), At(150, 5.0 + k)};  // 5, 6, 7: mean 6, std 1
    t.steps.back().targets_found = k == 0 ? 7 : 5;
    t.steps.back().trace = 100.0 + 10 * k;
    t.plans = 2;
    t.planning_time_s = 1.0;
    t.target_ids = {"a", "b"};
    t.found_at_end = {true, k == 2};
    // a: in view 3 times, detected twice. b: in view twice and detected
    // once in trial 1, never in view in trial 2, in view once and missed in
    // trial 3 (where it is found all the same, as a map may have it).
    t.sightings = {{3, 2},
                   k == 0   ? sim::TargetSightings{2, 1}
                   : k == 1 ? sim::TargetSightings{0, 0}
                            : sim::TargetSightings{1, 0}};
    result.trials.push_back(t);
  }
  TrialResult failed;
  failed.variant = "random";
  failed.trial = 4;
  failed.error = "server gone";
  result.trials.push_back(failed);
  const std::string md = SummaryMarkdown(result, 150);
  // Tr(P) 100, 110, 120: mean 110, std 10; one trial of three found all 7.
  EXPECT_NE(md.find("| random | 4 | 1 | 7.000 | 6.000 +- 1.000 | 0.577 | 110.0 +- 10.0 | 5.67 | "
                    "33 % | 0 |"),
            std::string::npos)
      << md;
  // Target a found in all three finished trials, b in one of three.
  EXPECT_NE(md.find("| variant | a | b |"), std::string::npos) << md;
  EXPECT_NE(md.find("| random | 100 % | 33 % |"), std::string::npos) << md;
  EXPECT_NE(md.find("random trial 4 failed: server gone"), std::string::npos) << md;
  // b is missed in trials 1 (detected, outvoted) and 2 (never in view); six
  // targets in view (3 + 2 + 3 + 0 + 3 + 1) / 6 = 2 times each, four of six
  // at least twice.
  EXPECT_NE(md.find("| random | 6 | 2 | 1 | 0 | 1 | 2.00 | 67 % |"), std::string::npos) << md;
  const std::string csv = TargetsCsv(result);
  EXPECT_NE(csv.find("random,1,b,2,1,0\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("random,3,b,1,0,1\n"), std::string::npos) << csv;
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 7) << csv;  // header + 2 x 3
}

TEST(EvaluationTest, SightingsCsvHasARowPerTimeATargetWasInView) {
  EvalResult result;
  TrialResult t;
  t.variant = "oaipp";
  t.trial = 3;
  t.target_ids = {"p1", "p2"};
  // p2 detected from 11.25 m, then missed from 13 m; an index past the
  // targets (a log that does not match them) is left out.
  t.sighting_log = {{.target = 1,
                     .mission_time_s = 6.7,
                     .altitude_m = 11.25,
                     .detected = true,
                     .mean_after = 0.8765},
                    {.target = 1,
                     .mission_time_s = 20.0,
                     .altitude_m = 13.0,
                     .detected = false,
                     .mean_after = 0.59444},
                    {.target = 2, .mission_time_s = 26.7, .altitude_m = 10.0}};
  result.trials.push_back(t);
  TrialResult failed;
  failed.variant = "oaipp";
  failed.trial = 4;
  failed.error = "server gone";
  result.trials.push_back(failed);
  EXPECT_EQ(SightingsCsv(result),
            "variant,trial,target,time_s,altitude_m,detected,mean_after\n"
            "oaipp,3,p2,6.7,11.25,1,0.8765\n"
            "oaipp,3,p2,20.0,13.00,0,0.5944\n");
}

}  // namespace
}  // namespace oaipp::client
