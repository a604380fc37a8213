// oaipp-client: flies simulated UAV missions against an oaipp-server.
//
//   oaipp-client run client/scenarios/e1.json --out=out/e1
//   oaipp-client health
//   oaipp-client map missions/m-000001 --png=map.png
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/strings/str_cat.h"
#include "client/evaluation.h"
#include "client/mission_runner.h"
#include "client/scenario.h"

ABSL_FLAG(std::string, server, "127.0.0.1:50051", "address of the oaipp-server (host:port)");
ABSL_FLAG(std::string, out, "",
          "run: folder for steps.csv and map.png (default out/<scenario name>)");
ABSL_FLAG(bool, keep, false, "run: keep the mission on the server afterwards");
ABSL_FLAG(std::string, png, "", "map: file to write the map image to");
ABSL_FLAG(int, trials, 25, "eval: trials per planner (seeds 1..trials)");
ABSL_FLAG(int, parallel, 2, "eval: missions flown at once");
ABSL_FLAG(double, plan_deadline_s, 0.0, "eval: deadline of each PlanPath call (0: none)");
ABSL_FLAG(std::string, scenario, "client/scenarios/e1.json", "eval: the scenario file");

namespace {

constexpr char kUsage[] = R"(oaipp-client COMMAND [ARGS] [FLAGS]

Commands:
  run SCENARIO.json   fly the scenario's mission against the server; prints a
                      progress line per measurement (time, RSE, Tr(P), targets
                      found) and writes steps.csv and map.png to --out
  health              check that the server answers
  map MISSION --png=FILE
                      write a mission's map image (mean | std deviation)
  eval E1|E2          many trials as concurrent missions (with a progress bar):
                      E1 = OA-IPP, lawnmower and random; E2 = adaptive against
                      non-adaptive OA-IPP; on --scenario (default the E1 file).
                      Writes trials.csv, summary.md and rse.png to --out
                      (default out/eval/E1 or E2).

Flags: --server=HOST:PORT (default 127.0.0.1:50051), --out, --keep, --png,
       --trials (25), --parallel (2), --plan_deadline_s (0: none), --scenario.)";

using oaipp::client::Client;

int Fail(const absl::Status& status) {
  std::fprintf(stderr, "error: %s\n", std::string(status.ToString()).c_str());
  return 1;
}

int Run(const std::string& path) {
  absl::StatusOr<oaipp::v1::Scenario> scenario = oaipp::client::LoadScenarioFile(path);
  if (!scenario.ok()) return Fail(scenario.status());
  absl::StatusOr<oaipp::client::Simulation> sim = oaipp::client::Simulation::Create(*scenario);
  if (!sim.ok())
    return Fail(
        absl::Status(sim.status().code(), absl::StrCat(path, ": ", sim.status().message())));
  Client client = Client::Connect(absl::GetFlag(FLAGS_server));
  if (absl::Status up = client.WaitUntilServing(absl::Seconds(10)); !up.ok()) return Fail(up);
  std::printf("scenario %s: %d targets, %.0f s budget, planner %s\n", scenario->name().c_str(),
              sim->num_targets(), sim->config().budget_s,
              oaipp::PlannerKindName(sim->config().planner.kind).c_str());
  std::printf("%8s %8s %8s %8s %10s %10s\n", "time_s", "RSE", "Tr(P)", "found", "path_m",
              "collisions");
  auto progress = [&](const oaipp::client::StepRecord& s) {
    std::printf("%8.1f %8.3f %8.2f %5d/%-2d %10.1f %10d\n", s.mission_time_s, s.rse, s.trace,
                s.targets_found, sim->num_targets(), s.path_length_m, s.collisions);
    std::fflush(stdout);
  };
  absl::StatusOr<oaipp::client::RunResult> result =
      oaipp::client::RunScenario(client, *scenario, *sim, progress, absl::GetFlag(FLAGS_keep));
  if (!result.ok()) return Fail(result.status());
  std::string out = absl::GetFlag(FLAGS_out);
  if (out.empty()) out = absl::StrCat("out/", scenario->name().empty() ? "run" : scenario->name());
  std::filesystem::create_directories(out);
  std::ofstream(out + "/steps.csv") << oaipp::client::StepsCsv(result->steps);
  std::ofstream(out + "/map.png", std::ios::binary) << result->final_map_png;
  const oaipp::client::StepRecord& last = result->steps.back();
  std::printf(
      "done: %d plans (%.1f s planning), RSE %.3f -> %.3f, %d/%d targets found, "
      "%d collisions; wrote %s/steps.csv and %s/map.png\n",
      result->plans, result->planning_time_s, result->steps.front().rse, last.rse,
      last.targets_found, sim->num_targets(), last.collisions, out.c_str(), out.c_str());
  return last.collisions == 0 ? 0 : 3;
}

int Eval(const std::string& experiment) {
  std::vector<oaipp::PlannerKind> planners;
  std::string paper;
  if (experiment == "E1") {
    planners = {oaipp::PlannerKind::kOaIpp, oaipp::PlannerKind::kLawnmower,
                oaipp::PlannerKind::kRandom};
    paper = "oaipp=5.17 lawnmower=5.85 random=6.22";
  } else if (experiment == "E2") {
    planners = {oaipp::PlannerKind::kOaIpp, oaipp::PlannerKind::kOaIppNonAdaptive};
    paper = "oaipp=5.17 oaipp_nonadaptive=5.29";
  } else {
    return Fail(absl::InvalidArgumentError(
        absl::StrCat("eval: unknown experiment '", experiment, "' (E1 or E2)")));
  }
  absl::StatusOr<oaipp::v1::Scenario> scenario =
      oaipp::client::LoadScenarioFile(absl::GetFlag(FLAGS_scenario));
  if (!scenario.ok()) return Fail(scenario.status());
  Client probe = Client::Connect(absl::GetFlag(FLAGS_server));
  if (absl::Status up = probe.WaitUntilServing(absl::Seconds(10)); !up.ok()) return Fail(up);
  oaipp::client::EvalOptions options{.trials = absl::GetFlag(FLAGS_trials),
                                     .parallel = absl::GetFlag(FLAGS_parallel),
                                     .plan_deadline_s = absl::GetFlag(FLAGS_plan_deadline_s)};
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
  absl::StatusOr<oaipp::client::EvalResult> result = oaipp::client::RunEvaluation(
      absl::GetFlag(FLAGS_server), *scenario, planners, options, progress);
  if (!result.ok()) return Fail(result.status());
  std::string out = absl::GetFlag(FLAGS_out);
  if (out.empty()) out = "out/eval/" + experiment;
  std::filesystem::create_directories(out);
  std::ofstream(out + "/trials.csv") << oaipp::client::TrialsCsv(*result);
  const double budget = result->grid_s.empty() ? 0.0 : result->grid_s.back();
  const std::string summary = oaipp::client::SummaryMarkdown(*result, budget);
  std::ofstream(out + "/summary.md") << summary;
  std::printf("%s\n", summary.c_str());
  const std::string plot = absl::StrCat("/usr/bin/python3 client/plots/plot_curves.py ", out,
                                        "/trials.csv rse ", out, "/rse.png --title '", experiment,
                                        ": RSE over time, mean +- std' --paper ", paper);
  if (std::system(plot.c_str()) != 0) {
    std::fprintf(stderr, "warning: the figure was not drawn (%s)\n", plot.c_str());
  }
  std::printf("wrote %s/trials.csv, %s/summary.md, %s/rse.png\n", out.c_str(), out.c_str(),
              out.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  absl::SetProgramUsageMessage(kUsage);
  std::vector<char*> args = absl::ParseCommandLine(argc, argv);
  if (args.size() < 2) {
    std::fprintf(stderr, "%s\n", kUsage);
    return 2;
  }
  const std::string command = args[1];
  if (command == "run" && args.size() == 3) return Run(args[2]);
  if (command == "eval" && args.size() == 3) return Eval(args[2]);
  if (command == "health" && args.size() == 2) {
    Client client = Client::Connect(absl::GetFlag(FLAGS_server));
    absl::Status up = client.WaitUntilServing(absl::Seconds(5));
    if (!up.ok()) return Fail(up);
    std::printf("%s: serving\n", absl::GetFlag(FLAGS_server).c_str());
    return 0;
  }
  if (command == "map" && args.size() == 3 && !absl::GetFlag(FLAGS_png).empty()) {
    Client client = Client::Connect(absl::GetFlag(FLAGS_server));
    absl::StatusOr<oaipp::v1::GetMapResponse> map = client.GetMap(args[2], false, true);
    if (!map.ok()) return Fail(map.status());
    std::ofstream(absl::GetFlag(FLAGS_png), std::ios::binary) << map->png();
    std::printf("wrote %s (Tr(P) = %.3f)\n", absl::GetFlag(FLAGS_png).c_str(), map->trace());
    return 0;
  }
  std::fprintf(stderr, "%s\n", kUsage);
  return 2;
}
