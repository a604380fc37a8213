// ESDF build and update times on the paper's E1 world (docs/method.md §10):
// 30 x 30 x 26 m volume, one 4 x 10 x 26 m building.
//
//   build/tests/bench/environment/environment_bench --benchmark_repetitions=5
#include <benchmark/benchmark.h>

#include "core/environment/environment.h"

namespace oaipp {
namespace {

const Aabb kVolume{{-15, -15, 0}, {15, 15, 26}};
const Shape kBuilding = Box{{0, -1, 13}, {10, 4, 26}, 0.0};

void BM_EsdfBuildE1(benchmark::State& state) {
  const double voxel_m = state.range(0) / 100.0;
  auto esdf = Esdf::Create(kVolume, {.voxel_size_m = voxel_m});
  const std::vector<const Shape*> shapes{&kBuilding};
  for (auto _ : state) {
    esdf->Rebuild(shapes);
    benchmark::DoNotOptimize(esdf->values().data());
  }
  state.counters["voxels"] = static_cast<double>(esdf->values().size());
  state.SetLabel(std::to_string(voxel_m) + " m voxels");
}
BENCHMARK(BM_EsdfBuildE1)->Arg(20)->Arg(10)->Unit(benchmark::kMillisecond);

// Adding a 4 x 4 x 13 m low-rise block next to the building: the update
// recomputes only the region it can change.
void BM_EsdfAddObstacleE1(benchmark::State& state) {
  auto env = Environment::Create(kVolume, {.voxel_size_m = 0.2});
  (void)env->Apply({.add = {{"building", kBuilding}}});
  const Obstacle block{"block", Box{{9, 9, 6.5}, {4, 4, 13}, 0.0}};
  for (auto _ : state) {
    (void)env->Apply({.add = {block}});
    state.PauseTiming();
    (void)env->Apply({.remove = {"block"}});
    state.ResumeTiming();
  }
  state.counters["recomputed_fraction"] =
      static_cast<double>(env->esdf().last_recomputed_voxels()) / env->esdf().values().size();
}
BENCHMARK(BM_EsdfAddObstacleE1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace oaipp
