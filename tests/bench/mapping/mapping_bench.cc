// Benchmarks of the field map's hot paths (docs/method.md §3) on the paper's
// 1600-cell map (40 x 40 cells of 0.75 m, paper preset).
//
// BM_KalmanUpdate/h: one GpMap::Update with the visible footprint of a camera
//   at the field centre, altitude h m, no obstacles (m cells: 192 at 10 m).
//   Each iteration also times a plain Eigen product W * W^T (W: n x m) on the
//   same data sizes, interleaved so that both see the same machine state;
//   the counter `ratio` = update time / product time (target <= 1.5).
// BM_KalmanUpdateOpenBlas/h: the same update on Eigen and on OpenBLAS
//   (core/mapping/dense_backend.h) in one run; counter `speedup`.
// BM_EigenWWt/h: that product alone, for reference.
// BM_TraceAfterUpdate/h: the planner's cheap O(n m^2) trace prediction.
// BM_PriorCovariance: building P0 for 1600 cells.
//
//   mapping_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <chrono>
#include <random>
#include <string>
#include <vector>

#include "benchmark/benchmark.h"
#include "core/mapping/camera.h"
#include "core/mapping/dense_backend.h"
#include "core/mapping/gp_map.h"

namespace oaipp {
namespace {

const FieldGrid& Grid() {
  static const FieldGrid grid = *FieldGrid::FromBounds(Vec2(-15, -15), Vec2(15, 15), 0.75);
  return grid;
}

const GpMap& PriorMap() {
  static const GpMap* map = new GpMap(*GpMap::Create(Grid(), GpParams::PaperPreset(0.75)));
  return *map;
}

// Observations of the visible footprint from (0, 0, altitude_m), labels
// alternating 0 / 1.
std::vector<CellObservation> FootprintObservations(double altitude_m) {
  const std::vector<int> cells =
      DownwardCamera{}.VisibleFootprintCells(Grid(), Vec3(0, 0, altitude_m), nullptr);
  std::vector<double> labels(cells.size());
  for (std::size_t i = 0; i < labels.size(); ++i) labels[i] = static_cast<double>(i % 2);
  return *LabelsToObservations(Grid(), SensorNoise{}, altitude_m, cells, labels);
}

Eigen::MatrixXd RandomW(int m) {
  std::mt19937 rng(1);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd w(Grid().num_cells(), m);
  for (Eigen::Index i = 0; i < w.size(); ++i) w.data()[i] = normal(rng);
  return w;
}

void BM_KalmanUpdate(benchmark::State& state) {
  const std::vector<CellObservation> obs = FootprintObservations(state.range(0));
  const int m = static_cast<int>(obs.size());
  const Eigen::MatrixXd w = RandomW(m);
  Eigen::MatrixXd product(w.rows(), w.rows());
  GpMap map = PriorMap().Clone();
  map.Unshare();  // the copy is not what is timed
  double update_s = 0.0;
  double product_s = 0.0;
  using Clock = std::chrono::steady_clock;
  for (auto _ : state) {
    // Untimed: start every update from the prior (the cost does not depend
    // on the values, but this keeps every iteration identical).
    map = PriorMap().Clone();
    map.Unshare();  // the copy is not what is timed
    const auto t0 = Clock::now();
    const absl::Status status = map.Update(obs);
    const auto t1 = Clock::now();
    product.noalias() = w * w.transpose();
    const auto t2 = Clock::now();
    if (!status.ok()) state.SkipWithError(std::string(status.message()).c_str());
    benchmark::DoNotOptimize(product.data());
    benchmark::ClobberMemory();
    const double u = std::chrono::duration<double>(t1 - t0).count();
    state.SetIterationTime(u);
    update_s += u;
    product_s += std::chrono::duration<double>(t2 - t1).count();
  }
  const double iterations = static_cast<double>(state.iterations());
  state.counters["m"] = m;
  state.counters["update_ms"] = 1e3 * update_s / iterations;
  state.counters["wwt_ms"] = 1e3 * product_s / iterations;
  state.counters["ratio"] = update_s / product_s;
}
BENCHMARK(BM_KalmanUpdate)
    ->Arg(5)
    ->Arg(10)
    ->Arg(26)
    ->UseManualTime()
    ->MinTime(1.0)  // at least two updates at 26 m
    ->Unit(benchmark::kMillisecond);

// One GpMap::Update on Eigen and on OpenBLAS (dense_backend.h), in turn in
// each iteration so both see the same machine state; the counter
// `speedup` = Eigen time / OpenBLAS time.
void BM_KalmanUpdateOpenBlas(benchmark::State& state) {
  const std::vector<CellObservation> obs = FootprintObservations(state.range(0));
  GpMap map = PriorMap().Clone();
  map.Unshare();  // the copy is not what is timed
  double eigen_s = 0.0;
  double blas_s = 0.0;
  using Clock = std::chrono::steady_clock;
  const absl::StatusOr<DenseBackend> blas = DenseBackend::OpenBlas();
  if (!blas.ok()) {
    state.SkipWithError(std::string(blas.status().message()).c_str());
    return;
  }
  const std::string kernel = blas->name();
  for (auto _ : state) {
    map = PriorMap().Clone();
    map.Unshare();  // the copy is not what is timed
    const auto t0 = Clock::now();
    absl::Status status = map.Update(obs);
    const auto t1 = Clock::now();
    map = PriorMap().Clone();
    map.Unshare();  // the copy is not what is timed
    map.set_dense_backend(*blas);
    const auto t2 = Clock::now();
    status.Update(map.Update(obs));
    const auto t3 = Clock::now();
    if (!status.ok()) state.SkipWithError(std::string(status.message()).c_str());
    const double b = std::chrono::duration<double>(t3 - t2).count();
    state.SetIterationTime(b);
    blas_s += b;
    eigen_s += std::chrono::duration<double>(t1 - t0).count();
  }
  const double iterations = static_cast<double>(state.iterations());
  state.counters["m"] = static_cast<double>(obs.size());
  state.counters["eigen_ms"] = 1e3 * eigen_s / iterations;
  state.counters["openblas_ms"] = 1e3 * blas_s / iterations;
  state.counters["speedup"] = eigen_s / blas_s;
  state.SetLabel(kernel);
}
BENCHMARK(BM_KalmanUpdateOpenBlas)
    ->Arg(5)
    ->Arg(10)
    ->Arg(26)
    ->UseManualTime()
    ->MinTime(1.0)
    ->Unit(benchmark::kMillisecond);

void BM_EigenWWt(benchmark::State& state) {
  const int m = static_cast<int>(FootprintObservations(state.range(0)).size());
  const Eigen::MatrixXd w = RandomW(m);
  Eigen::MatrixXd product(w.rows(), w.rows());
  for (auto _ : state) {
    product.noalias() = w * w.transpose();
    benchmark::DoNotOptimize(product.data());
    benchmark::ClobberMemory();
  }
  state.counters["m"] = m;
}
BENCHMARK(BM_EigenWWt)->Arg(5)->Arg(10)->Arg(26)->Unit(benchmark::kMillisecond);

void BM_TraceAfterUpdate(benchmark::State& state) {
  const std::vector<CellObservation> obs = FootprintObservations(state.range(0));
  const GpMap& map = PriorMap();
  for (auto _ : state) {
    auto trace = TraceAfterUpdate(map.Covariance(), obs);
    benchmark::DoNotOptimize(trace);
  }
  state.counters["m"] = static_cast<double>(obs.size());
}
BENCHMARK(BM_TraceAfterUpdate)->Arg(5)->Arg(10)->Arg(26)->Unit(benchmark::kMillisecond);

void BM_PriorCovariance(benchmark::State& state) {
  const GpParams params = GpParams::PaperPreset(0.75);
  for (auto _ : state) {
    auto p0 = PriorCovariance(Grid(), params);
    benchmark::DoNotOptimize(p0);
  }
}
BENCHMARK(BM_PriorCovariance)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace oaipp
