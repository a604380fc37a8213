// oaipp-client eval E8: OA-IPP through the service on the SAREnv datasets
// against the benchmark's five baselines (client/cli/e8.h), written to --out
// as metrics.csv, summary.md, each flight's paths and a picture per
// dataset (docs/experiments.md, E8). Every dataset, team size and budget is
// a flight of its own: a team's UAVs plan around each other, so a team
// that stops at a smaller budget flies differently before it stops.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

#include "absl/flags/declare.h"
#include "absl/flags/flag.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "client/cli/commands.h"
#include "client/cli/e8.h"
#include "client/sarenv/baselines.h"
#include "core/common/status_macros.h"
#include "sim/simulation.h"

ABSL_DECLARE_FLAG(int, parallel);

ABSL_FLAG(std::string, sarenv, "../shared/sarenv",
          "eval E8: the folder of the SAREnv datasets (N/heatmap.npy, N/meta.json)");
ABSL_FLAG(std::string, datasets, "1-10", "eval E8: datasets, numbers and ranges (1-10, 1,3,5-7)");
ABSL_FLAG(std::string, sarenv_size, "medium", "eval E8: the disc's size (small, medium, large)");
ABSL_FLAG(std::string, agents, "1,2,5", "eval E8: team sizes, comma-separated (1..16)");
ABSL_FLAG(std::string, budgets_m, "20000,100000",
          "eval E8: total path budgets of the team, metres, comma-separated; each is flown");
ABSL_FLAG(uint64_t, victim_seed, 1,
          "eval E8: the base seed of the victims and of Greedy's and RandomWalk's steps (as "
          "oaipp-sarenv --seed)");
ABSL_FLAG(int, e8_waypoints, 3, "eval E8: OA-IPP's waypoints per plan, the UAV's included");
ABSL_FLAG(double, e8_speed_m_s, 15.0, "eval E8: the UAVs' top speed, m/s");
ABSL_FLAG(double, e8_length_scale_m, 9.0, "eval E8: the map's length scale, metres");
ABSL_FLAG(double, e8_shot_spacing_m, 60.0, "eval E8: metres between shots at top speed");
ABSL_FLAG(double, e8_fov_deg, 45.0, "eval E8: the planner's camera's field of view, both axes");

namespace oaipp::client::cli {
namespace {

using sarenv::Baseline;

absl::StatusOr<std::vector<int>> IntList(absl::string_view flag, const std::string& text,
                                         bool ranges) {
  std::vector<int> out;
  for (absl::string_view part : absl::StrSplit(text, ',', absl::SkipWhitespace())) {
    std::vector<absl::string_view> ends = absl::StrSplit(part, '-');
    int a = 0, b = 0;
    if (ends.size() > 2 || (ends.size() == 2 && !ranges) || !absl::SimpleAtoi(ends[0], &a) ||
        !absl::SimpleAtoi(ends.back(), &b) || a < 1 || b < a || b > 1000) {
      return absl::InvalidArgumentError(absl::StrCat("--", flag, ": expected positive numbers",
                                                     ranges ? " or ranges" : "",
                                                     ", comma-separated"));
    }
    for (int k = a; k <= b; ++k) out.push_back(k);
  }
  if (out.empty()) return absl::InvalidArgumentError(absl::StrCat("--", flag, ": empty"));
  return out;
}

struct Place {
  int number = 0;
  sarenv::SearchArea area;
  std::vector<sarenv::PointXY> victims;
};

// One flight: a dataset and a team size.
struct Flight {
  const Place* place = nullptr;
  int agents = 0;
  double budget_m = 0.0;
  std::vector<sarenv::Polyline> paths;  // in the CRS, whole
  int plans = 0;
  double planning_s = 0.0;
  double wall_s = 0.0;
  std::string error;
};

// Every `stride`-th point of each path (and its last), "uav,x_m,y_m".
std::string PathsCsv(const std::vector<sarenv::Polyline>& paths, std::size_t stride) {
  std::string csv = "uav,x_m,y_m\n";
  for (std::size_t k = 0; k < paths.size(); ++k) {
    const sarenv::Polyline& line = paths[k];
    for (std::size_t i = 0; i < line.size(); i += stride) {
      absl::StrAppendFormat(&csv, "%d,%.3f,%.3f\n", k + 1, line[i].x_m, line[i].y_m);
    }
    if (!line.empty() && (line.size() - 1) % stride != 0) {
      absl::StrAppendFormat(&csv, "%d,%.3f,%.3f\n", k + 1, line.back().x_m, line.back().y_m);
    }
  }
  return csv;
}

}  // namespace

int EvalE8() {
  absl::StatusOr<std::vector<int>> datasets =
      IntList("datasets", absl::GetFlag(FLAGS_datasets), true);
  if (!datasets.ok()) return Fail(datasets.status());
  absl::StatusOr<std::vector<int>> agents = IntList("agents", absl::GetFlag(FLAGS_agents), false);
  if (!agents.ok()) return Fail(agents.status());
  std::vector<double> budgets;
  for (absl::string_view part :
       absl::StrSplit(absl::GetFlag(FLAGS_budgets_m), ',', absl::SkipWhitespace())) {
    double b = 0;
    if (!absl::SimpleAtod(part, &b) || !(b >= 100 && b <= 1e7)) {
      return Fail(absl::InvalidArgumentError(
          "--budgets_m: expected metres in [100, 1e7], comma-separated"));
    }
    budgets.push_back(b);
  }
  if (budgets.empty()) return Fail(absl::InvalidArgumentError("--budgets_m: empty"));
  std::sort(budgets.begin(), budgets.end());
  budgets.erase(std::unique(budgets.begin(), budgets.end()), budgets.end());
  const int parallel = absl::GetFlag(FLAGS_parallel);
  if (parallel < 1) return Fail(absl::InvalidArgumentError("--parallel: must be >= 1"));
  E8Settings settings;
  settings.num_waypoints = absl::GetFlag(FLAGS_e8_waypoints);
  settings.max_speed_m_s = absl::GetFlag(FLAGS_e8_speed_m_s);
  settings.length_scale_m = absl::GetFlag(FLAGS_e8_length_scale_m);
  settings.shot_spacing_m = absl::GetFlag(FLAGS_e8_shot_spacing_m);
  settings.fov_deg = absl::GetFlag(FLAGS_e8_fov_deg);
  const uint64_t seed = absl::GetFlag(FLAGS_victim_seed);

  std::vector<Place> places;
  for (const int number : *datasets) {
    absl::StatusOr<sarenv::Dataset> dataset =
        sarenv::LoadDataset(absl::StrCat(absl::GetFlag(FLAGS_sarenv), "/", number));
    if (!dataset.ok()) return Fail(dataset.status());
    absl::StatusOr<sarenv::SearchArea> area =
        sarenv::CropToSize(*dataset, absl::GetFlag(FLAGS_sarenv_size));
    if (!area.ok()) return Fail(area.status());
    Place p;
    p.number = number;
    p.area = *std::move(area);
    p.victims = sarenv::DrawVictims(p.area, 100, sarenv::DatasetSeed(seed, number));
    places.push_back(std::move(p));
  }
  std::vector<Flight> flights;
  for (const Place& p : places) {
    for (const int n : *agents) {
      for (const double budget : budgets) {
        Flight f;
        f.place = &p;
        f.agents = n;
        f.budget_m = budget;
        flights.push_back(std::move(f));
      }
    }
  }
  // Every mission checked as the server will check it before any flies.
  for (const Flight& f : flights) {
    absl::StatusOr<v1::Scenario> s = E8Scenario(f.place->area, f.agents, f.budget_m, settings);
    absl::StatusOr<sim::Simulation> checked =
        s.ok() ? sim::Simulation::Create(*s) : absl::StatusOr<sim::Simulation>(s.status());
    if (!checked.ok()) return Fail(checked.status());
  }
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = OpenChannel();
  if (!channel.ok()) return Fail(channel.status());
  Client probe(*channel, Options());
  if (absl::Status up = probe.WaitUntilServing(absl::Seconds(10)); !up.ok()) return Fail(up);

  const auto started = std::chrono::steady_clock::now();
  std::atomic<std::size_t> next{0};
  std::atomic<int> done{0};
  std::mutex print_mu;
  auto worker = [&] {
    Client client(*channel, Options());
    for (std::size_t j = next++; j < flights.size(); j = next++) {
      Flight& f = flights[j];
      const auto t0 = std::chrono::steady_clock::now();
      absl::StatusOr<v1::Scenario> s = E8Scenario(f.place->area, f.agents, f.budget_m, settings);
      absl::StatusOr<sim::Simulation> sim =
          s.ok() ? sim::Simulation::Create(*s) : absl::StatusOr<sim::Simulation>(s.status());
      absl::StatusOr<RunResult> run =
          sim.ok() ? RunScenario(client, *s, *sim) : absl::StatusOr<RunResult>(sim.status());
      f.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (run.ok()) {
        f.paths = FlownPathsInCrs(*run, f.place->area);
        f.plans = run->plans;
        f.planning_s = run->planning_time_s;
      } else {
        f.error = std::string(run.status().message());
      }
      const int finished = ++done;
      std::lock_guard<std::mutex> lock(print_mu);
      double km = 0;
      for (const sarenv::Polyline& line : f.paths) km += sarenv::PolylineLength_m(line) / 1000;
      std::fprintf(
          stderr,
          "[%d/%zu] dataset %d, n = %d, %.0f km: %s%.1f km flown, %d plans, %.0f s (%.0f s in "
          "all)\n",
          finished, flights.size(), f.place->number, f.agents, f.budget_m / 1000,
          f.error.empty() ? "" : ("FAILED: " + f.error + "; ").c_str(), km, f.plans, f.wall_s,
          std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
    }
  };
  std::vector<std::thread> threads;
  for (int k = 0; k < std::min<int>(parallel, static_cast<int>(flights.size())); ++k)
    threads.emplace_back(worker);
  for (std::thread& t : threads) t.join();

  std::string out = absl::GetFlag(FLAGS_out);
  if (out.empty()) out = "out/eval/E8";
  std::error_code ec;
  std::filesystem::create_directories(out + "/paths", ec);
  if (ec) return Fail(absl::PermissionDeniedError(absl::StrCat("--out: ", ec.message())));
  std::vector<E8Row> rows;
  int failed = 0;
  for (const Flight& f : flights) {
    if (!f.error.empty()) {
      ++failed;
      continue;
    }
    std::ofstream(absl::StrFormat("%s/paths/%d_n%d_%.0fkm_OA-IPP.csv", out, f.place->number,
                                  f.agents, f.budget_m / 1000))
        << PathsCsv(f.paths, 10);
    absl::StatusOr<sarenv::PathMetrics> m = sarenv::EvaluatePaths(
        f.place->area, sarenv::CutToBudget(f.paths, f.budget_m), f.place->victims);
    if (!m.ok()) return Fail(m.status());
    E8Row row;
    row.dataset = std::to_string(f.place->number);
    row.algorithm = "OA-IPP";
    row.agents = f.agents;
    row.budget_m = f.budget_m;
    row.metrics = *m;
    row.plans = f.plans;
    row.planning_s = f.planning_s;
    row.flight_wall_s = f.wall_s;
    for (const sarenv::Polyline& line : f.paths) {
      if (sarenv::PolylineLength_m(line) < f.budget_m / f.agents - 1e-6) row.short_of_budget = true;
    }
    rows.push_back(std::move(row));
  }
  for (const Place& p : places) {
    const std::string stem = absl::StrCat(out, "/paths/", p.number);
    if (absl::Status w = sarenv::WriteSearchArea(p.area, stem + "_map.npy", stem + "_map.json");
        !w.ok()) {
      return Fail(w);
    }
    for (const Baseline b : {Baseline::kSpiral, Baseline::kConcentric, Baseline::kPizza,
                             Baseline::kGreedy, Baseline::kRandomWalk}) {
      for (const int n : *agents) {
        for (const double budget : budgets) {
          absl::StatusOr<std::vector<sarenv::Polyline>> paths =
              sarenv::PlanBaseline(b, p.area, n, budget,
                                   sarenv::BaselineSeed(sarenv::DatasetSeed(seed, p.number), b, n));
          if (!paths.ok()) return Fail(paths.status());
          absl::StatusOr<sarenv::PathMetrics> m = sarenv::EvaluatePaths(p.area, *paths, p.victims);
          if (!m.ok()) return Fail(m.status());
          E8Row row;
          row.dataset = std::to_string(p.number);
          row.algorithm = std::string(sarenv::BaselineName(b));
          row.agents = n;
          row.budget_m = budget;
          row.metrics = *m;
          rows.push_back(std::move(row));
          if (b == Baseline::kGreedy) {
            std::ofstream(absl::StrFormat("%s_n%d_%.0fkm_Greedy.csv", stem, n, budget / 1000))
                << PathsCsv(*paths, 1);
          }
        }
      }
    }
  }
  std::ofstream csv(out + "/metrics.csv");
  csv << E8Csv(rows);
  std::string summary = E8SummaryMarkdown(rows);
  if (failed > 0) absl::StrAppend(&summary, "\n", failed, " flight(s) failed; see the log.\n");
  std::ofstream md(out + "/summary.md");
  md << summary;
  if (!csv || !md)
    return Fail(absl::PermissionDeniedError(absl::StrCat("--out: cannot write ", out)));
  std::printf("%s\n", summary.c_str());
  // The folder goes to the script as one argument, quoted for the shell.
  std::string quoted = "'";
  for (const char c : out) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  quoted += "'";
  const std::string plot = absl::StrCat("/usr/bin/python3 client/plots/plot_e8.py ", quoted);
  if (std::system(plot.c_str()) != 0) {
    std::fprintf(stderr, "warning: the pictures were not drawn (%s; run it from the repository)\n",
                 plot.c_str());
  }
  std::printf("wrote to %s: metrics.csv, summary.md, paths/, e8_*.png\n", out.c_str());
  return failed == 0 ? 0 : 1;
}

}  // namespace oaipp::client::cli
