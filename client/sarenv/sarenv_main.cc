// oaipp-sarenv: runs the SAREnv benchmark's baselines through this
// project's evaluator and compares the scores with the published ones.
//
//   oaipp-sarenv --sarenv=../shared/sarenv --datasets=1-10 --size=medium
//     --agents=1,2,5 --budget_m=100000 --algorithms=spiral,concentric,pizza,greedy,randomwalk
//     --seed=1 --out=out/sarenv --published=../shared/sarenv/results
//
// Writes OUT/metrics.csv (one row per dataset x algorithm x drone count)
// and, with --published, OUT/published_check.csv; prints the largest
// relative differences and the means per algorithm. Seeds, all for
// std::mt19937_64: dataset N's victims use seed * 1000000 + N * 1000, and
// Greedy / RandomWalk with n drones on it seed * 1000000 + N * 1000 +
// 10 n + 1 / + 2.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "client/sarenv/baselines.h"
#include "client/sarenv/dataset.h"
#include "client/sarenv/metrics.h"

ABSL_FLAG(std::string, sarenv, "../shared/sarenv", "folder holding the datasets 1/, 2/, ...");
ABSL_FLAG(std::string, datasets, "1-10",
          "datasets to run: numbers and ranges, e.g. 1-10 or 1,3,5-7");
ABSL_FLAG(std::string, size, "medium", "small, medium, large or xlarge");
ABSL_FLAG(std::string, agents, "1,2,5", "numbers of drones, comma-separated");
ABSL_FLAG(double, budget_m, 100000, "total flight budget of all drones, metres");
ABSL_FLAG(std::string, algorithms, "spiral,concentric,pizza,greedy,randomwalk",
          "baselines, comma-separated; empty: none (e.g. only --export_crops)");
ABSL_FLAG(uint64_t, seed, 1, "base seed of victims and random planners (see the file comment)");
ABSL_FLAG(int, victims, 100, "victims drawn per dataset");
ABSL_FLAG(std::string, out, "out/sarenv", "folder for metrics.csv and published_check.csv");
ABSL_FLAG(std::string, published, "",
          "folder of the benchmark's comparative_metrics_results_n{N}_budget{B}.csv files");
ABSL_FLAG(double, tolerance, 1e-5,
          "with --published: exit 1 when a deterministic baseline differs by more (relative)");
ABSL_FLAG(bool, greedy_random_ties, false,
          "Greedy: break ties of equal positive gain at random instead of taking the first "
          "neighbour in the benchmark's fixed order");
ABSL_FLAG(std::string, export_crops, "",
          "folder to write each dataset's crop to as N_SIZE.npy and N_SIZE.json");

namespace {

using oaipp::sarenv::Baseline;

absl::StatusOr<std::vector<int>> ParseList(absl::string_view text, bool ranges) {
  std::vector<int> out;
  for (absl::string_view part : absl::StrSplit(text, ',', absl::SkipWhitespace())) {
    std::vector<absl::string_view> ends = absl::StrSplit(part, absl::MaxSplits('-', 1));
    int lo = 0;
    int hi = 0;
    if (!absl::SimpleAtoi(ends[0], &lo) ||
        !absl::SimpleAtoi(ends.size() == 2 && ranges ? ends[1] : ends[0], &hi) ||
        (ends.size() == 2 && !ranges) || lo < 1 || hi < lo) {
      return absl::InvalidArgumentError(absl::StrCat("bad list item '", part, "'"));
    }
    for (int v = lo; v <= hi; ++v) out.push_back(v);
  }
  if (out.empty()) return absl::InvalidArgumentError(absl::StrCat("empty list '", text, "'"));
  return out;
}

// Published numbers keyed by (dataset, algorithm, drones, budget).
struct Published {
  double likelihood, time_discounted, area_km2, length_km;
};
using PublishedKey = std::tuple<std::string, std::string, int, long>;

absl::Status LoadPublished(const std::string& dir, int n, long budget, absl::string_view size,
                           std::map<PublishedKey, Published>& out) {
  const std::string path =
      absl::StrCat(dir, "/comparative_metrics_results_n", n, "_budget", budget, ".csv");
  std::ifstream in(path);
  if (!in) return absl::NotFoundError(absl::StrCat(path, ": cannot open"));
  std::string line;
  std::getline(in, line);
  std::map<std::string, size_t> column;
  std::vector<std::string> header = absl::StrSplit(line, ',');
  for (size_t i = 0; i < header.size(); ++i) column[header[i]] = i;
  const char* kNeeded[] = {"Dataset",
                           "Algorithm",
                           "Environment Size",
                           "n_agents",
                           "Budget (m)",
                           "Likelihood Score",
                           "Time-Discounted Score",
                           "Area Covered (km²)",
                           "Total Path Length (km)"};
  for (const char* name : kNeeded) {
    if (!column.contains(name)) {
      return absl::InvalidArgumentError(absl::StrCat(path, ": no column '", name, "'"));
    }
  }
  while (std::getline(in, line)) {
    const std::vector<std::string> f = absl::StrSplit(line, ',');
    if (f.size() != header.size() || f[column["Environment Size"]] != size) continue;
    double lik = 0, td = 0, area = 0, length = 0, b = 0;
    int agents = 0;
    if (!absl::SimpleAtod(f[column["Likelihood Score"]], &lik) ||
        !absl::SimpleAtod(f[column["Time-Discounted Score"]], &td) ||
        !absl::SimpleAtod(f[column["Area Covered (km²)"]], &area) ||
        !absl::SimpleAtod(f[column["Total Path Length (km)"]], &length) ||
        !absl::SimpleAtod(f[column["Budget (m)"]], &b) ||
        !absl::SimpleAtoi(f[column["n_agents"]], &agents)) {
      return absl::InvalidArgumentError(absl::StrCat(path, ": bad row '", line, "'"));
    }
    out[{f[column["Dataset"]], f[column["Algorithm"]], agents, std::lround(b)}] = {lik, td, area,
                                                                                   length};
  }
  return absl::OkStatus();
}

double RelDiff(double ours, double theirs) {
  return theirs != 0 ? std::abs(ours - theirs) / std::abs(theirs) : std::abs(ours - theirs);
}

int Fail(const absl::Status& status) {
  std::fprintf(stderr, "oaipp-sarenv: %s\n", status.ToString().c_str());
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  absl::SetProgramUsageMessage(
      "Scores the SAREnv baselines with this project's evaluator (see the flags).");
  absl::ParseCommandLine(argc, argv);
  const auto started = std::chrono::steady_clock::now();
  const std::string size = absl::GetFlag(FLAGS_size);
  const double budget = absl::GetFlag(FLAGS_budget_m);
  const uint64_t seed = absl::GetFlag(FLAGS_seed);
  const std::string out_dir = absl::GetFlag(FLAGS_out);
  const std::string published_dir = absl::GetFlag(FLAGS_published);
  const std::string export_dir = absl::GetFlag(FLAGS_export_crops);
  oaipp::sarenv::BaselineOptions planner_options;
  planner_options.greedy_random_ties = absl::GetFlag(FLAGS_greedy_random_ties);

  absl::StatusOr<std::vector<int>> datasets = ParseList(absl::GetFlag(FLAGS_datasets), true);
  if (!datasets.ok()) return Fail(datasets.status());
  absl::StatusOr<std::vector<int>> agents = ParseList(absl::GetFlag(FLAGS_agents), false);
  if (!agents.ok()) return Fail(agents.status());
  std::vector<Baseline> algorithms;
  for (absl::string_view name :
       absl::StrSplit(absl::GetFlag(FLAGS_algorithms), ',', absl::SkipWhitespace())) {
    absl::StatusOr<Baseline> b = oaipp::sarenv::ParseBaseline(name);
    if (!b.ok()) return Fail(b.status());
    algorithms.push_back(*b);
  }
  std::map<PublishedKey, Published> published;
  if (!published_dir.empty()) {
    for (const int n : *agents) {
      if (absl::Status s = LoadPublished(published_dir, n, std::lround(budget), size, published);
          !s.ok()) {
        return Fail(s);
      }
    }
  }

  std::ofstream metrics_csv;
  std::ofstream check_csv;
  if (!algorithms.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(out_dir, ec);
    metrics_csv.open(out_dir + "/metrics.csv");
    if (!metrics_csv) return Fail(absl::PermissionDeniedError(out_dir + "/metrics.csv"));
    metrics_csv << "dataset,size,algorithm,n_agents,budget_m,likelihood,time_discounted,"
                   "victims_found_pct,area_covered_km2,total_path_length_km,seconds\n";
    if (!published_dir.empty()) {
      check_csv.open(out_dir + "/published_check.csv");
      if (!check_csv) return Fail(absl::PermissionDeniedError(out_dir + "/published_check.csv"));
      check_csv << "dataset,algorithm,n_agents,budget_m,deterministic,likelihood,"
                   "published_likelihood,rel_diff_likelihood,time_discounted,"
                   "published_time_discounted,rel_diff_time_discounted,area_covered_km2,"
                   "published_area_covered_km2,rel_diff_area,total_path_length_km,"
                   "published_total_path_length_km\n";
    }
  }

  // Per (algorithm, n): sums for the means; per algorithm: largest differences.
  std::map<std::pair<std::string, int>, std::array<double, 6>> sums;
  std::map<std::string, std::array<double, 3>> worst;
  bool out_of_tolerance = false;
  for (const int number : *datasets) {
    const std::string name = std::to_string(number);
    absl::StatusOr<oaipp::sarenv::Dataset> dataset =
        oaipp::sarenv::LoadDataset(absl::StrCat(absl::GetFlag(FLAGS_sarenv), "/", name));
    if (!dataset.ok()) return Fail(dataset.status());
    absl::StatusOr<oaipp::sarenv::SearchArea> area = oaipp::sarenv::CropToSize(*dataset, size);
    if (!area.ok()) return Fail(area.status());
    double mass = 0;
    for (const double v : area->heatmap.values) mass += v;
    std::fprintf(stderr, "dataset %s: %s crop %lld x %lld, mass %.6f\n", name.c_str(), size.c_str(),
                 static_cast<long long>(area->heatmap.rows),
                 static_cast<long long>(area->heatmap.cols), mass);
    if (!export_dir.empty()) {
      std::error_code ec;
      std::filesystem::create_directories(export_dir, ec);
      const std::string stem = absl::StrCat(export_dir, "/", name, "_", size);
      if (absl::Status s = WriteSearchArea(*area, stem + ".npy", stem + ".json"); !s.ok()) {
        return Fail(s);
      }
    }
    const uint64_t dataset_seed = oaipp::sarenv::DatasetSeed(seed, number);
    const std::vector<oaipp::sarenv::PointXY> victims =
        oaipp::sarenv::DrawVictims(*area, absl::GetFlag(FLAGS_victims), dataset_seed);
    for (const Baseline algorithm : algorithms) {
      const std::string algo(oaipp::sarenv::BaselineName(algorithm));
      for (const int n : *agents) {
        const auto t0 = std::chrono::steady_clock::now();
        const uint64_t plan_seed = oaipp::sarenv::BaselineSeed(dataset_seed, algorithm, n);
        absl::StatusOr<std::vector<oaipp::sarenv::Polyline>> paths =
            oaipp::sarenv::PlanBaseline(algorithm, *area, n, budget, plan_seed, planner_options);
        if (!paths.ok()) return Fail(paths.status());
        absl::StatusOr<oaipp::sarenv::PathMetrics> m =
            oaipp::sarenv::EvaluatePaths(*area, *paths, victims);
        if (!m.ok()) return Fail(m.status());
        const double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        metrics_csv << absl::StrFormat("%s,%s,%s,%d,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.3f\n",
                                       name, size, algo, n, budget, m->likelihood,
                                       m->time_discounted, m->victims_found_pct,
                                       m->area_covered_km2, m->total_path_length_km, seconds);
        std::fprintf(
            stderr, "  %-10s n=%d likelihood %.6f td %.6f victims %5.1f%% area %.4f km2 (%.2f s)\n",
            algo.c_str(), n, m->likelihood, m->time_discounted, m->victims_found_pct,
            m->area_covered_km2, seconds);
        auto& s = sums[{algo, n}];
        s[0] += m->likelihood;
        s[1] += m->time_discounted;
        s[2] += m->victims_found_pct;
        s[3] += m->area_covered_km2;
        s[4] += m->total_path_length_km;
        s[5] += 1;
        const auto it = published.find({name, algo, n, std::lround(budget)});
        if (published_dir.empty() || it == published.end()) continue;
        const Published& p = it->second;
        const double d[3] = {RelDiff(m->likelihood, p.likelihood),
                             RelDiff(m->time_discounted, p.time_discounted),
                             RelDiff(m->area_covered_km2, p.area_km2)};
        auto& w = worst[algo];
        for (int i = 0; i < 3; ++i) w[i] = std::max(w[i], d[i]);
        const bool deterministic = !oaipp::sarenv::IsRandomized(algorithm);
        if (deterministic && std::max({d[0], d[1], d[2]}) > absl::GetFlag(FLAGS_tolerance)) {
          out_of_tolerance = true;
        }
        check_csv << absl::StrFormat(
            "%s,%s,%d,%.17g,%d,%.17g,%.17g,%.3e,%.17g,%.17g,%.3e,%.17g,%.17g,%.3e,%.17g,%.17g\n",
            name, algo, n, budget, deterministic ? 1 : 0, m->likelihood, p.likelihood, d[0],
            m->time_discounted, p.time_discounted, d[1], m->area_covered_km2, p.area_km2, d[2],
            m->total_path_length_km, p.length_km);
      }
    }
  }

  if (!algorithms.empty()) {
    std::printf("Means over datasets %s (%s, budget %.0f m):\n",
                absl::GetFlag(FLAGS_datasets).c_str(), size.c_str(), budget);
    std::printf("%-10s %3s %10s %12s %9s %10s %9s\n", "algorithm", "n", "likelihood", "time-disc.",
                "victims%", "area km2", "length km");
    for (const auto& [key, s] : sums) {
      std::printf("%-10s %3d %10.6f %12.8f %9.2f %10.4f %9.3f\n", key.first.c_str(), key.second,
                  s[0] / s[5], s[1] / s[5], s[2] / s[5], s[3] / s[5], s[4] / s[5]);
    }
  }
  if (!worst.empty()) {
    std::printf("Largest relative difference to the published numbers:\n");
    std::printf("%-10s %12s %12s %12s\n", "algorithm", "likelihood", "time-disc.", "area");
    for (const auto& [algo, w] : worst) {
      const bool random = algo == "Greedy" || algo == "RandomWalk";
      std::printf("%-10s %12.3e %12.3e %12.3e%s\n", algo.c_str(), w[0], w[1], w[2],
                  random ? "  (random: not expected to match)" : "");
    }
  }
  std::fprintf(stderr, "done in %.1f s\n",
               std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
  return out_of_tolerance ? 1 : 0;
}
