// oaipp-client: flies simulated UAV missions against an oaipp-server.
//
//   oaipp-client run client/scenarios/e1.json --out=out/e1
//   oaipp-client health
//   oaipp-client map missions/m-000001 --png=map.png
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/strings/str_cat.h"
#include "client/mission_runner.h"
#include "client/scenario.h"

ABSL_FLAG(std::string, server, "127.0.0.1:50051", "address of the oaipp-server (host:port)");
ABSL_FLAG(std::string, out, "",
          "run: folder for steps.csv and map.png (default out/<scenario name>)");
ABSL_FLAG(bool, keep, false, "run: keep the mission on the server afterwards");
ABSL_FLAG(std::string, png, "", "map: file to write the map image to");

namespace {

constexpr char kUsage[] = R"(oaipp-client COMMAND [ARGS] [FLAGS]

Commands:
  run SCENARIO.json   fly the scenario's mission against the server; prints a
                      progress line per measurement (time, RSE, Tr(P), targets
                      found) and writes steps.csv and map.png to --out
  health              check that the server answers
  map MISSION --png=FILE
                      write a mission's map image (mean | std deviation)

Flags: --server=HOST:PORT (default 127.0.0.1:50051), --out, --keep, --png.)";

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
