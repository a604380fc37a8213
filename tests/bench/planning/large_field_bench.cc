// OA-IPP replans on a large field through the planner's window
// (core/planning/large_field.h): a 300 x 300 m field at 1 m (90,000 cells)
// with 50 seeded buildings of 8-25 m sides and 6-35 m heights (the ESDF
// benchmark's large world), paper preset, the default OA-IPP planner
// (N = 3, 12 x 45 CMA-ES evaluations), objective and window on OpenBLAS
// where it loads.
//
// BM_ReplanLargeField: before each replan one 10 m shot is fused at the
// UAV's place (paused), so every timed replan pays what PlanPath would after
// a measurement: the map's refactorisation and mean, the window and the
// plan. The UAV is put at seeded clear places across the field. Counters:
// window_ms and plan_ms (means of the parts), map_mb and rss_mb.
//
//   build/tests/bench/planning/large_field_bench --benchmark_repetitions=3
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <chrono>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/planning/large_field.h"
#include "core/planning/planners.h"

namespace oaipp {
namespace {

constexpr double kHalfField = 150.0;

std::unique_ptr<Environment> LargeWorld() {
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> xy(-140, 140), side(8, 25), height(6, 35), yaw(0, 1.57);
  std::vector<Obstacle> buildings;
  for (int b = 0; b < 50; ++b) {
    const double h = height(rng);
    buildings.push_back({absl::StrCat("b", b),
                         Box{{xy(rng), xy(rng), 0.5 * h}, {side(rng), side(rng), h}, yaw(rng)}});
  }
  auto env = Environment::Create({{-kHalfField, -kHalfField, 2}, {kHalfField, kHalfField, 30}},
                                 {.voxel_size_m = 0.5});
  if (!env.ok() || !env->Apply({.add = std::move(buildings)}).ok()) return nullptr;
  return std::make_unique<Environment>(std::move(env).value());
}

void BM_ReplanLargeField(benchmark::State& state) {
  const std::unique_ptr<Environment> env = LargeWorld();
  auto grid = FieldGrid::FromBounds({-kHalfField, -kHalfField}, {kHalfField, kHalfField}, 1.0);
  auto map = SparseGpMap::Create(*grid, GpParams::PaperPreset(1.0));
  if (env == nullptr || !map.ok() ||
      !map->FuseNearCertainZeros(
              grid->CellsUnderObstacles([&](const Vec3& p) { return env->IsInsideObstacle(p); }))
           .ok()) {
    state.SkipWithError("cannot build the world or the map");
    return;
  }
  absl::StatusOr<DenseBackend> blas = DenseBackend::OpenBlas();
  const DenseBackend backend = blas.ok() ? *blas : DenseBackend();
  state.SetLabel(backend.name());
  PlannerConfig config{.kind = PlannerKind::kOaIpp};
  config.common.information.dense_backend = backend;
  auto planner = MakePlanner(config);
  const LargeFieldPlanning large{.backend = backend};
  const DownwardCamera camera;
  const SensorNoise noise;
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> xy(-kHalfField + 5, kHalfField - 5);
  double window_s = 0.0, plan_s = 0.0;
  int plans = 0;
  for (auto _ : state) {
    state.PauseTiming();
    UavState start;
    do {
      start.position_W = Vec3(xy(rng), xy(rng), 10.0);
    } while (env->SignedDistance(start.position_W) < 3.0);
    const std::vector<int> cells = camera.FootprintCells(*grid, start.position_W);
    std::vector<double> labels(cells.size(), 0.0);
    auto shot = LabelsToObservations(*grid, noise, 10.0, cells, labels);
    if (!shot.ok() || !map->Update(*shot).ok()) state.SkipWithError("cannot fuse a shot");
    const PlanningContext context{env.get(), nullptr, camera, noise, 1.0};
    state.ResumeTiming();

    const auto t0 = std::chrono::steady_clock::now();
    auto window = WindowAround(*grid, start.position_W.head<2>(), large.half_width_m);
    auto local = WindowMap(*map, *window, large.window, backend);
    const auto t1 = std::chrono::steady_clock::now();
    if (!local.ok()) {
      state.SkipWithError(std::string(local.status().message()).c_str());
      return;
    }
    PlanningContext windowed = context;
    windowed.map = &*local;
    auto path = (*planner)->Plan(windowed, start, absl::InfiniteFuture());
    const auto t2 = std::chrono::steady_clock::now();
    if (!path.ok()) state.SkipWithError(std::string(path.status().message()).c_str());
    window_s += std::chrono::duration<double>(t1 - t0).count();
    plan_s += std::chrono::duration<double>(t2 - t1).count();
    ++plans;
  }
  state.counters["window_ms"] = 1e3 * window_s / plans;
  state.counters["plan_ms"] = 1e3 * plan_s / plans;
  state.counters["map_mb"] = static_cast<double>(map->bytes()) / (1 << 20);
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  state.counters["rss_mb"] = static_cast<double>(usage.ru_maxrss) / 1024.0;
}
BENCHMARK(BM_ReplanLargeField)->Unit(benchmark::kMillisecond)->Iterations(10);

}  // namespace
}  // namespace oaipp
