// What the large-field prior costs in search (docs/method.md §3.9-3.10):
// E1 flown in process with the mission's dense Matérn 3/2 map and again
// with the sparse map forced on, every plan on a window that covers the
// whole field (so on the sparse prior's exact posterior), same seeds.
//
// Each mission: the E1 world and start, default OA-IPP (N = 3, 12 x 45
// CMA-ES evaluations), a 150 s budget, every shot fused with the ground
// truth's labels (no detector; the labels' variances follow the paper's
// noise model). Reports each seed's final RSE with both maps, their means
// and standard errors, and the mean paired difference with its standard
// error.
//
//   build/tests/bench/planning/sparse_prior_e1 --seeds=25
#include <cmath>
#include <cstdio>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "core/planning/large_field.h"
#include "core/planning/planners.h"
#include "server/library_settings.h"
#include "tests/core/planning/scenes.h"

ABSL_FLAG(int, seeds, 25, "missions per map, seeds 1 .. N");
ABSL_FLAG(double, budget_s, 150.0, "flight budget per mission, seconds");

namespace oaipp {
namespace {

struct MeanSe {
  double mean = 0.0;
  double se = 0.0;
};

MeanSe Summarise(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  const double mean = sum / static_cast<double>(v.size());
  double ss = 0.0;
  for (double x : v) ss += (x - mean) * (x - mean);
  const double sd = v.size() > 1 ? std::sqrt(ss / static_cast<double>(v.size() - 1)) : 0.0;
  return {mean, sd / std::sqrt(static_cast<double>(v.size()))};
}

// Flies E1 with `seed` and returns the final RSE; with `sparse` the map is
// the sparse one and every plan runs on a window of the whole field.
double Fly(std::uint32_t seed, bool sparse, double budget_s) {
  testing::Scene scene = testing::E1();
  const FieldGrid grid = scene.map->grid();
  absl::StatusOr<SparseGpMap> sparse_map = SparseGpMap::Create(grid, GpParams::PaperPreset(0.75));
  const std::vector<int> covered =
      grid.CellsUnderObstacles([&](const Vec3& p) { return scene.env->IsInsideObstacle(p); });
  if (!sparse_map.ok() || !sparse_map->FuseNearCertainZeros(covered).ok()) std::abort();
  Eigen::VectorXd truth = Eigen::VectorXd::Zero(grid.num_cells());
  for (int c : scene.target_cells) truth[c] = 1.0;

  PlannerConfig config{.kind = PlannerKind::kOaIpp};
  config.common.seed = seed;
  auto planner = MakePlanner(config);
  // Wider than the field: the window is all of it.
  const LargeFieldPlanning whole{.half_width_m = 1000.0};
  const DownwardCamera camera;
  const SensorNoise noise;
  UavState state = scene.start;
  PlanningContext context = scene.View();
  while (state.mission_time_s < budget_s) {
    context.remaining_budget_s = budget_s - state.mission_time_s;
    absl::StatusOr<PlannedPath> path =
        sparse ? PlanInWindow(**planner, *sparse_map, context, state, absl::InfiniteFuture(), whole)
               : (*planner)->Plan(context, state, absl::InfiniteFuture());
    if (!path.ok()) {
      std::fprintf(stderr, "seed %u: %s\n", seed, std::string(path.status().message()).c_str());
      std::abort();
    }
    const double fly_s = std::min(path->trajectory.Duration(), budget_s - state.mission_time_s);
    for (const MeasurementPose& pose : path->measurement_poses) {
      if (pose.t_s > fly_s) break;
      const std::vector<int> cells =
          camera.VisibleFootprintCells(grid, pose.position_W, scene.env.get());
      std::vector<double> labels;
      for (int c : cells) labels.push_back(truth[c]);
      auto obs = LabelsToObservations(grid, noise, pose.position_W.z(), cells, labels);
      if (!obs.ok() || !(sparse ? sparse_map->Update(*obs) : scene.map->Update(*obs)).ok()) {
        std::abort();
      }
    }
    state = StateAlong(path->trajectory, fly_s, state.mission_time_s);
    context.next_shot_mission_s = path->next_shot_mission_s;
  }
  if (!sparse) return (scene.map->Mean() - truth).norm();
  absl::StatusOr<Eigen::VectorXd> mean = sparse_map->Mean();
  if (!mean.ok()) std::abort();
  return (*mean - truth).norm();
}

}  // namespace
}  // namespace oaipp

int main(int argc, char** argv) {
  // As the server does: the numeric libraries' threads (server/library_settings.h).
  if (!oaipp::server::SetUpNumericLibrariesOrSay()) return 1;
  absl::ParseCommandLine(argc, argv);
  const int seeds = absl::GetFlag(FLAGS_seeds);
  const double budget_s = absl::GetFlag(FLAGS_budget_s);
  if (seeds < 2 || !(budget_s > 0.0)) {
    std::fprintf(stderr, "--seeds >= 2 and --budget_s > 0\n");
    return 2;
  }
  std::vector<double> dense, sparse, difference;
  std::printf("seed  dense RSE  sparse RSE\n");
  for (int seed = 1; seed <= seeds; ++seed) {
    dense.push_back(oaipp::Fly(static_cast<std::uint32_t>(seed), false, budget_s));
    sparse.push_back(oaipp::Fly(static_cast<std::uint32_t>(seed), true, budget_s));
    difference.push_back(sparse.back() - dense.back());
    std::printf("%4d  %9.4f  %10.4f\n", seed, dense.back(), sparse.back());
    std::fflush(stdout);
  }
  const oaipp::MeanSe d = oaipp::Summarise(dense), s = oaipp::Summarise(sparse),
                      p = oaipp::Summarise(difference);
  std::printf(
      "E1 RSE at %.0f s over %d seeds: dense %.3f +- %.3f, sparse %.3f +- %.3f (mean +- SE)\n",
      budget_s, seeds, d.mean, d.se, s.mean, s.se);
  std::printf(
      "sparse - dense, paired by seed: %+.3f +- %.3f; |mean difference| / dense SE = %.2f\n",
      p.mean, p.se, std::abs(s.mean - d.mean) / d.se);
  return 0;
}
