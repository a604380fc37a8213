// Benchmarks of the large-field map (core/mapping/sparse_gp_map.h) at the
// sizes issue targets name: 300 x 300 cells of 1 m (90,000 cells) and
// 500 x 500 cells of 2 m (a square kilometre, 250,000 cells), paper preset.
//
// BM_SparseCreate/side/res_cm: the prior's fit, its lattice precision, the
//   symbolic analysis and the first factorisation. Counters: states,
//   factor_nonzeros, map_mb (what the map holds).
// BM_SparseFuse/side/res_cm: one Update with the footprint of a camera at
//   10 m, at places that move across the field: the fusion alone, what a
//   measurement costs before anyone asks for the map.
// BM_SparseMean/side/res_cm: that Update and then the mean (the numeric
//   refactorisation and the mean's solve).
// BM_SparseVariances/side/res_cm: every field cell's variance after an
//   update (the refactorisation and the selected inversion), on a map whose
//   variances were computed once before.
// BM_SparseWindow/side/res_cm/half_width_m: the planner's dense window
//   (core/mapping/field_window.h) around a point that moves across the
//   field, after an update whose mean is already computed, on OpenBLAS where
//   it loads. Counter: window_cells.
//
//   sparse_map_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <vector>

#include "benchmark/benchmark.h"
#include "core/mapping/camera.h"
#include "core/mapping/field_window.h"
#include "core/mapping/sparse_gp_map.h"

namespace oaipp {
namespace {

FieldGrid Grid(const benchmark::State& state) {
  const int side = static_cast<int>(state.range(0));
  const double res = state.range(1) / 100.0;
  return *FieldGrid::Create(Vec2(-0.5 * side * res, -0.5 * side * res), side, side, res);
}

std::vector<CellObservation> Shot(const FieldGrid& grid, int i) {
  const DownwardCamera camera;
  const SensorNoise noise;
  const Vec2 lo = grid.min_W(), hi = grid.max_W();
  const double f = 0.1 + 0.8 * ((i * 37) % 100) / 100.0;
  const double g = 0.1 + 0.8 * ((i * 61) % 100) / 100.0;
  const Vec3 p(lo.x() + f * (hi.x() - lo.x()), lo.y() + g * (hi.y() - lo.y()), 10.0);
  std::vector<CellObservation> obs;
  for (int cell : camera.FootprintCells(grid, p)) {
    obs.push_back(
        {.cell = cell, .value = cell % 7 == 0 ? 1.0 : 0.0, .variance = noise.Variance(10.0)});
  }
  return obs;
}

void BM_SparseCreate(benchmark::State& state) {
  const FieldGrid grid = Grid(state);
  const GpParams params = GpParams::PaperPreset(grid.resolution_m());
  for (auto _ : state) {
    absl::StatusOr<SparseGpMap> map = SparseGpMap::Create(grid, params);
    if (!map.ok()) {
      state.SkipWithError(std::string(map.status().message()).c_str());
      return;
    }
    state.counters["states"] = map->prior().num_states();
    state.counters["factor_nonzeros"] = static_cast<double>(map->factor_nonzeros());
    state.counters["map_mb"] = static_cast<double>(map->bytes()) / (1 << 20);
  }
}

void BM_SparseFuse(benchmark::State& state) {
  const FieldGrid grid = Grid(state);
  absl::StatusOr<SparseGpMap> map =
      SparseGpMap::Create(grid, GpParams::PaperPreset(grid.resolution_m()));
  int i = 0;
  std::size_t cells = 0;
  for (auto _ : state) {
    const std::vector<CellObservation> obs = Shot(grid, i++);
    cells = obs.size();
    if (!map->Update(obs).ok()) state.SkipWithError("update failed");
  }
  state.counters["footprint_cells"] = static_cast<double>(cells);
}

void BM_SparseMean(benchmark::State& state) {
  const FieldGrid grid = Grid(state);
  absl::StatusOr<SparseGpMap> map =
      SparseGpMap::Create(grid, GpParams::PaperPreset(grid.resolution_m()));
  int i = 0;
  for (auto _ : state) {
    if (!map->Update(Shot(grid, i++)).ok()) state.SkipWithError("update failed");
    benchmark::DoNotOptimize(map->Mean());
  }
}

void BM_SparseVariances(benchmark::State& state) {
  const FieldGrid grid = Grid(state);
  absl::StatusOr<SparseGpMap> map =
      SparseGpMap::Create(grid, GpParams::PaperPreset(grid.resolution_m()));
  // A mission asks for its map more than once: the first variance map,
  // which allocates the inversion's workspace, is not timed.
  benchmark::DoNotOptimize(map->Variances());
  int i = 0;
  for (auto _ : state) {
    state.PauseTiming();
    if (!map->Update(Shot(grid, i++)).ok()) state.SkipWithError("update failed");
    state.ResumeTiming();
    benchmark::DoNotOptimize(map->Variances());
  }
}

void BM_SparseWindow(benchmark::State& state) {
  const FieldGrid grid = Grid(state);
  absl::StatusOr<SparseGpMap> map =
      SparseGpMap::Create(grid, GpParams::PaperPreset(grid.resolution_m()));
  absl::StatusOr<DenseBackend> blas = DenseBackend::OpenBlas();
  const DenseBackend backend = blas.ok() ? *blas : DenseBackend();
  state.SetLabel(backend.name());
  int i = 0;
  int cells = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const std::vector<CellObservation> shot = Shot(grid, i++);
    if (!map->Update(shot).ok() || !map->Mean().ok()) state.SkipWithError("update failed");
    const absl::StatusOr<FieldWindow> window =
        WindowAround(grid, grid.CellCentreXY(shot.front().cell), state.range(2));
    state.ResumeTiming();
    absl::StatusOr<GpMap> local = WindowMap(*map, *window, {}, backend);
    if (!local.ok()) state.SkipWithError(std::string(local.status().message()).c_str());
    cells = local->num_cells();
  }
  state.counters["window_cells"] = cells;
}

void Sizes(benchmark::internal::Benchmark* b) {
  b->Args({300, 100})->Args({500, 200})->Unit(benchmark::kMillisecond);
}
BENCHMARK(BM_SparseCreate)->Apply(Sizes)->Iterations(1);
BENCHMARK(BM_SparseFuse)->Apply(Sizes)->Iterations(50);
BENCHMARK(BM_SparseMean)->Apply(Sizes)->Iterations(10);
BENCHMARK(BM_SparseVariances)->Apply(Sizes)->Iterations(3);
BENCHMARK(BM_SparseWindow)
    ->Args({300, 100, 20})
    ->Args({300, 100, 30})
    ->Args({500, 200, 40})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(5);

}  // namespace
}  // namespace oaipp
