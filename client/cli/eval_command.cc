// oaipp-client eval: many trials of an experiment's variants as concurrent
// missions (client/cli/evaluation.h), written to --out with a summary and
// figures (docs/experiments.md).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "absl/flags/flag.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "client/cli/commands.h"
#include "client/cli/evaluation.h"
#include "client/cli/team_evaluation.h"
#include "core/common/status_macros.h"
#include "sim/random_world.h"
#include "sim/scenario.h"

ABSL_FLAG(int, trials, 25, "eval: trials per planner (seeds first_trial..first_trial+trials-1)");
ABSL_FLAG(int, first_trial, 1,
          "eval: the first trial's seed, in [1, 1000000] (fresh seeds for a setting chosen on "
          "the first ones)");
ABSL_FLAG(int, parallel, 2, "eval: missions flown at once");
ABSL_FLAG(double, plan_budget_s, 0.0,
          "eval: wall-clock seconds each replan may take (0: the planner's full evaluation "
          "budget); the planner is anytime and returns its best path at the budget");
ABSL_FLAG(
    std::string, scenario, "",
    "eval: the scenario file (default client/scenarios/e1.json; e4.json, e5.json, e6.json for "
    "E4, E5, E6; e5.json, the single UAV, for E7)");
ABSL_FLAG(std::string, team_scenarios,
          "client/scenarios/e5-team2.json,client/scenarios/e5-team4.json,"
          "client/scenarios/e5-team8.json",
          "eval E7: comma-separated team scenarios flown beside --scenario's single UAV "
          "(default e5.json), one team size each");
ABSL_FLAG(double, e7_budget_s, 0,
          "eval E7: flight budget of every mission, seconds (0: the scenarios' own, 150 s); "
          "one UAV rarely finds all of E5's people in 150 s");
ABSL_FLAG(double, e3_budget_s, 300, "eval E3: flight budget of each mission, seconds");
ABSL_FLAG(double, confirmation_weight, 0.0,
          "eval E1, E4, E5, E6: > 0 adds the variant oaipp_confirm, OA-IPP with the confirmation "
          "objective at this weight (docs/method.md 6.4); 0 leaves it out");
ABSL_FLAG(double, confirmation_phase_s, 0.0,
          "eval: with --confirmation_weight, oaipp_confirm also confirms over the last this many "
          "seconds of its budget (PlannerSpec.confirmation_phase_s); 0: no phase");
ABSL_FLAG(double, confirmation_phase_weight, -1.0,
          "eval: with --confirmation_phase_s, the phase's weight on undecided cells "
          "(PlannerSpec.confirmation_phase_weight, >= 0); -1: the planner's default");
ABSL_FLAG(double, ambiguity_margin, -1.0,
          "eval: with --confirmation_phase_s, the margin around the decision threshold within "
          "which a cell counts as undecided (PlannerSpec.ambiguity_margin, in (0, 0.5]); -1: the "
          "planner's default");
ABSL_FLAG(double, second_look_weight, 0.0,
          "eval: with --confirmation_phase_s, the phase's weight on every other cell's "
          "variance, a second look at ground seen once (PlannerSpec.second_look_weight, >= 0); "
          "0: none");
ABSL_FLAG(double, second_look_sharpness, 0.0,
          "eval: with --second_look_weight, each cell earns it times exp(-this / variance) "
          "instead of its variance, falling with each look as the chance of a missed person "
          "does (PlannerSpec.second_look_sharpness, >= 0); 0: the variance");
ABSL_FLAG(std::string, variants, "",
          "eval: comma-separated variants to fly (e.g. oaipp_confirm); empty: all of the "
          "experiment's");

namespace oaipp::client::cli {
namespace {

// The variants of an experiment and the paper's values at the end.
struct Experiment {
  std::vector<oaipp::client::Variant> variants;
  std::string paper;   // label=value pairs for the figure
  std::string column;  // plotted over time
};

// The value of flag `name` when it is >= 0 and finite.
absl::StatusOr<double> NonNegativeFlag(absl::string_view name, double value) {
  if (value >= 0.0 && std::isfinite(value)) return value;
  return absl::InvalidArgumentError(absl::StrCat(name, ": must be >= 0 and finite"));
}

// Flag `name` applies to the confirmation phase: an error without one.
absl::Status NeedsPhase(absl::string_view name, double phase_s) {
  if (phase_s > 0.0) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(name, ": applies to the confirmation phase; set --confirmation_phase_s"));
}

absl::StatusOr<Experiment> MakeExperiment(const std::string& name,
                                          const oaipp::v1::Scenario& scenario) {
  using oaipp::PlannerKind;
  using oaipp::client::PlannerVariants;
  Experiment e;
  e.column = "rse";
  if (name == "E1") {
    e.variants = PlannerVariants(
        scenario, {PlannerKind::kOaIpp, PlannerKind::kLawnmower, PlannerKind::kRandom});
    e.paper = "oaipp=5.17 lawnmower=5.85 random=6.22";
  } else if (name == "E2") {
    e.variants = PlannerVariants(scenario, {PlannerKind::kOaIpp, PlannerKind::kOaIppNonAdaptive});
    e.paper = "oaipp=5.17 oaipp_nonadaptive=5.29";
  } else if (name == "E3") {
    // OA-IPP over seeded random worlds: trial k flies world k.
    e.column = "trace";
    oaipp::v1::Scenario base = scenario;
    base.mutable_mission()->set_budget_s(absl::GetFlag(FLAGS_e3_budget_s));
    for (auto kind : {oaipp::sim::BuildingKind::kLowRise, oaipp::sim::BuildingKind::kHighRise}) {
      for (int count : {5, 10, 15}) {
        const std::string label = absl::StrCat(oaipp::sim::BuildingKindName(kind), " ", count);
        e.variants.push_back(
            {label, [base, kind, count](int trial) -> absl::StatusOr<oaipp::v1::Scenario> {
               absl::StatusOr<oaipp::v1::Scenario> s = oaipp::sim::RandomWorld(
                   base, {.kind = kind,
                          .count = count,
                          .seed = static_cast<std::uint64_t>(1000 * count + trial)});
               if (!s.ok()) return s.status();
               s->set_name(absl::StrCat("e3-", count, "-", trial));
               s->set_seed(static_cast<std::uint64_t>(trial));
               s->mutable_mission()->mutable_planner()->set_kind(oaipp::v1::PLANNER_KIND_OAIPP);
               s->mutable_mission()->mutable_planner()->set_seed(static_cast<std::uint32_t>(trial));
               return s;
             }});
      }
    }
  } else if (name == "E6") {
    e.variants = PlannerVariants(
        scenario, {PlannerKind::kOaIpp, PlannerKind::kLawnmower, PlannerKind::kRandom});
  } else if (name == "E7") {
    std::vector<oaipp::v1::Scenario> sizes = {scenario};
    for (absl::string_view path :
         absl::StrSplit(absl::GetFlag(FLAGS_team_scenarios), ',', absl::SkipEmpty())) {
      OAIPP_ASSIGN_OR_RETURN(oaipp::v1::Scenario team, LoadScenario(std::string(path)));
      sizes.push_back(std::move(team));
    }
    OAIPP_ASSIGN_OR_RETURN(const double budget,
                           NonNegativeFlag("--e7_budget_s", absl::GetFlag(FLAGS_e7_budget_s)));
    if (budget > 0.0) {
      for (oaipp::v1::Scenario& s : sizes) s.mutable_mission()->set_budget_s(budget);
    }
    OAIPP_ASSIGN_OR_RETURN(e.variants, oaipp::client::TeamVariants(sizes));
  } else if (name == "E4" || name == "E5") {
    e.variants = PlannerVariants(scenario, {PlannerKind::kOaIpp, PlannerKind::kLawnmower});
  } else if (name == "PRIOR") {
    // A search from a lost-person map: the adaptive objective on the map
    // as given, the detection objective (docs/method.md §6.6) and the
    // baselines.
    if (!scenario.has_prior_map_file() && !scenario.mission().gp().has_prior_map()) {
      return absl::InvalidArgumentError(
          "--scenario: eval PRIOR needs a scenario with a prior map (prior_map_file or "
          "mission.gp.prior_map)");
    }
    e.variants = PlannerVariants(scenario, {PlannerKind::kOaIpp, PlannerKind::kOaIppDetection,
                                            PlannerKind::kLawnmower, PlannerKind::kRandom});
  } else {
    return absl::InvalidArgumentError(absl::StrCat("eval: unknown experiment '", name,
                                                   "' (E1, E2, E3, E4, E5, E6, E7, E8 or PRIOR)"));
  }
  oaipp::client::ConfirmationOptions confirm;
  OAIPP_ASSIGN_OR_RETURN(confirm.weight, NonNegativeFlag("--confirmation_weight",
                                                         absl::GetFlag(FLAGS_confirmation_weight)));
  OAIPP_ASSIGN_OR_RETURN(
      confirm.phase_s,
      NonNegativeFlag("--confirmation_phase_s", absl::GetFlag(FLAGS_confirmation_phase_s)));
  if (confirm.phase_s > 0.0 && confirm.weight == 0.0) {
    return absl::InvalidArgumentError(
        "--confirmation_phase_s: applies to the oaipp_confirm variant; set --confirmation_weight");
  }
  if (const double w = absl::GetFlag(FLAGS_confirmation_phase_weight); w != -1.0) {
    if (!(w >= 0.0) || !std::isfinite(w)) {
      return absl::InvalidArgumentError(
          "--confirmation_phase_weight: must be >= 0 and finite, or -1 for the default");
    }
    OAIPP_RETURN_IF_ERROR(NeedsPhase("--confirmation_phase_weight", confirm.phase_s));
    confirm.phase_weight = w;
  }
  if (const double m = absl::GetFlag(FLAGS_ambiguity_margin); m != -1.0) {
    if (!(m > 0.0 && m <= 0.5)) {
      return absl::InvalidArgumentError(
          "--ambiguity_margin: must lie in (0, 0.5], or be -1 for the default");
    }
    OAIPP_RETURN_IF_ERROR(NeedsPhase("--ambiguity_margin", confirm.phase_s));
    confirm.ambiguity_margin = m;
  }
  OAIPP_ASSIGN_OR_RETURN(
      confirm.second_look_weight,
      NonNegativeFlag("--second_look_weight", absl::GetFlag(FLAGS_second_look_weight)));
  if (confirm.second_look_weight > 0.0) {
    OAIPP_RETURN_IF_ERROR(NeedsPhase("--second_look_weight", confirm.phase_s));
  }
  OAIPP_ASSIGN_OR_RETURN(
      confirm.second_look_sharpness,
      NonNegativeFlag("--second_look_sharpness", absl::GetFlag(FLAGS_second_look_sharpness)));
  if (confirm.second_look_sharpness > 0.0 && confirm.second_look_weight == 0.0) {
    return absl::InvalidArgumentError(
        "--second_look_sharpness: shapes the second look; set --second_look_weight");
  }
  if (confirm.weight > 0.0) {
    if (name != "E1" && name != "E4" && name != "E5" && name != "E6") {
      return absl::InvalidArgumentError(
          "--confirmation_weight: adds a variant to E1, E4, E5 and E6 only");
    }
    e.variants.push_back(oaipp::client::ConfirmationVariant(scenario, confirm));
  }
  const std::string wanted = absl::GetFlag(FLAGS_variants);
  std::vector<std::string> labels;
  if (!wanted.empty()) labels = absl::StrSplit(wanted, ',');
  absl::StatusOr<std::vector<oaipp::client::Variant>> selected =
      oaipp::client::SelectVariants(std::move(e.variants), labels, "--variants");
  if (!selected.ok()) return selected.status();
  e.variants = *std::move(selected);
  return e;
}

std::string DefaultScenario(const std::string& experiment) {
  if (experiment == "E4") return "client/scenarios/e4.json";
  if (experiment == "E5" || experiment == "E7") return "client/scenarios/e5.json";
  if (experiment == "E6") return "client/scenarios/e6.json";
  if (experiment == "PRIOR") return "client/scenarios/prior-demo.json";
  return "client/scenarios/e1.json";
}

}  // namespace

int Eval(const std::string& experiment) {
  if (experiment == "E8") return EvalE8();
  std::string scenario_path = absl::GetFlag(FLAGS_scenario);
  if (scenario_path.empty()) scenario_path = DefaultScenario(experiment);
  absl::StatusOr<oaipp::v1::Scenario> scenario = LoadScenario(scenario_path);
  if (!scenario.ok()) return Fail(scenario.status());
  absl::StatusOr<Experiment> e = MakeExperiment(experiment, *scenario);
  if (!e.ok()) return Fail(e.status());
  if (absl::GetFlag(FLAGS_trials) < 1 || absl::GetFlag(FLAGS_parallel) < 1 ||
      !(absl::GetFlag(FLAGS_plan_budget_s) >= 0) || !(absl::GetFlag(FLAGS_e3_budget_s) > 0)) {
    return Fail(absl::InvalidArgumentError(
        "--trials and --parallel must be >= 1, --plan_budget_s >= 0, --e3_budget_s > 0"));
  }
  const int first = absl::GetFlag(FLAGS_first_trial);
  if (first < 1 || first > oaipp::client::kMaxFirstTrial ||
      absl::GetFlag(FLAGS_trials) > oaipp::client::kMaxTrials) {
    return Fail(absl::InvalidArgumentError(
        absl::StrCat("--first_trial must lie in [1, ", oaipp::client::kMaxFirstTrial,
                     "] and --trials in [1, ", oaipp::client::kMaxTrials, "]")));
  }
  // E3 draws world k of density n from seed 1000 n + k: past trial 999 the
  // densities would share worlds.
  if (experiment == "E3" && first + absl::GetFlag(FLAGS_trials) - 1 > 999) {
    return Fail(absl::InvalidArgumentError(
        "--first_trial, --trials: E3's trials must end by trial 999 (world seeds are "
        "1000 x density + trial)"));
  }
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = OpenChannel();
  if (!channel.ok()) return Fail(channel.status());
  Client probe(*channel, Options());
  if (absl::Status up = probe.WaitUntilServing(absl::Seconds(10)); !up.ok()) return Fail(up);
  oaipp::client::EvalOptions options{.trials = absl::GetFlag(FLAGS_trials),
                                     .first_trial = absl::GetFlag(FLAGS_first_trial),
                                     .parallel = absl::GetFlag(FLAGS_parallel),
                                     .plan_budget_s = absl::GetFlag(FLAGS_plan_budget_s),
                                     .client = Options()};
  const auto start = absl::Now();
  auto progress = [&](int done, int total) {
    const double elapsed = absl::ToDoubleSeconds(absl::Now() - start);
    const double eta = elapsed / done * (total - done);
    const int width = 30, filled = width * done / total;
    std::fprintf(stderr, "\r[%s%s] %d/%d trials, %.0f s elapsed, ETA %.0f s   ",
                 std::string(filled, '#').c_str(), std::string(width - filled, ' ').c_str(), done,
                 total, elapsed, eta);
    if (done == total) std::fprintf(stderr, "\n");
  };
  absl::StatusOr<oaipp::client::EvalResult> result =
      oaipp::client::RunEvaluation(absl::GetFlag(FLAGS_server), e->variants, options, progress);
  if (!result.ok()) return Fail(result.status());
  std::string out = absl::GetFlag(FLAGS_out);
  if (out.empty()) out = "out/eval/" + experiment;
  std::filesystem::create_directories(out);
  std::ofstream(out + "/trials.csv") << oaipp::client::TrialsCsv(*result);
  std::ofstream(out + "/targets.csv") << oaipp::client::TargetsCsv(*result);
  std::ofstream(out + "/sightings.csv") << oaipp::client::SightingsCsv(*result);
  const double budget = result->grid_s.empty() ? 0.0 : result->grid_s.back();
  std::string summary = oaipp::client::SummaryMarkdown(*result, budget);
  if (experiment == "E7") {
    summary = absl::StrCat(oaipp::client::TeamSummaryMarkdown(*result, budget), "\n", summary);
  }
  std::ofstream(out + "/summary.md") << summary;
  std::printf("%s\n", summary.c_str());
  std::vector<std::string> written = {"trials.csv", "targets.csv", "sightings.csv", "summary.md"};
  // The final map of the first trial of each variant, with its flown path.
  for (const oaipp::client::TrialResult& t : result->trials) {
    if (t.map_png.empty()) continue;
    std::string file = absl::StrCat("map_", t.variant, ".png");
    std::replace(file.begin(), file.end(), ' ', '_');
    std::ofstream(out + "/" + file, std::ios::binary) << t.map_png;
    written.push_back(file);
  }
  const std::string figure = e->column + ".png";
  const std::string title =
      e->column == "rse" ? ": RSE over time, mean +- std" : ": Tr(P) over time, mean +- std";
  std::string plot =
      absl::StrCat("/usr/bin/python3 client/plots/plot_curves.py ", out, "/trials.csv ", e->column,
                   " ", out, "/", figure, " --title '", experiment, title, "'");
  if (!e->paper.empty()) absl::StrAppend(&plot, " --paper ", e->paper);
  if (std::system(plot.c_str()) != 0) {
    std::fprintf(stderr, "warning: the figure was not drawn (%s)\n", plot.c_str());
  } else {
    written.push_back(figure);
  }
  std::printf("wrote to %s: %s\n", out.c_str(), absl::StrJoin(written, ", ").c_str());
  return 0;
}

}  // namespace oaipp::client::cli
