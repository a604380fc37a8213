// ESDF build and update times on the paper's E1 world (docs/method.md §10):
// 30 x 30 x 26 m volume, one 4 x 10 x 26 m building; and on a large field
// (BM_EsdfBuildLargeField): 300 x 300 x 40 m with 50 seeded buildings of
// 8-25 m sides and 6-35 m heights, at voxel sizes that fit its memory.
//
//   build/tests/bench/environment/environment_bench --benchmark_repetitions=5
#include <benchmark/benchmark.h>

#include <random>
#include <string>
#include <vector>

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

void BM_EsdfBuildLargeField(benchmark::State& state) {
  const double voxel_m = state.range(0) / 100.0;
  const Aabb volume{{-150, -150, 0}, {150, 150, 40}};
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> xy(-140, 140), side(8, 25), height(6, 35), yaw(0, 1.57);
  std::vector<Shape> buildings;
  for (int b = 0; b < 50; ++b) {
    const double h = height(rng);
    buildings.push_back(Box{{xy(rng), xy(rng), 0.5 * h}, {side(rng), side(rng), h}, yaw(rng)});
  }
  std::vector<const Shape*> shapes;
  for (const Shape& b : buildings) shapes.push_back(&b);
  absl::StatusOr<Esdf> esdf = Esdf::Create(volume, {.voxel_size_m = voxel_m});
  if (!esdf.ok()) {
    state.SkipWithError(std::string(esdf.status().message()).c_str());
    return;
  }
  for (auto _ : state) {
    esdf->Rebuild(shapes);
    benchmark::DoNotOptimize(esdf->values().data());
  }
  state.counters["voxels"] = static_cast<double>(esdf->values().size());
  state.counters["grid_mb"] = static_cast<double>(esdf->MemoryBytes()) / (1 << 20);
  state.SetLabel(std::to_string(voxel_m) + " m voxels");
}
BENCHMARK(BM_EsdfBuildLargeField)->Arg(50)->Arg(40)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
}  // namespace oaipp
