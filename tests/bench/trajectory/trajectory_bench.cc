// Minimum-snap solve and limit-respecting planning times (docs/method.md §5).
// PlanMinSnap runs once per candidate path inside the CMA-ES loop, so its
// cost bounds the planner's evaluation rate.
//
//   build/tests/bench/trajectory/trajectory_bench --benchmark_repetitions=5
#include <benchmark/benchmark.h>

#include <random>

#include "core/trajectory/min_snap.h"

namespace oaipp {
namespace {

// Seeded waypoints in the paper's E1 volume (30 x 30 m, 2..26 m altitude).
std::vector<Vec3> Waypoints(int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-15, 15), z(2, 26);
  std::vector<Vec3> w;
  for (int i = 0; i < count; ++i) w.emplace_back(xy(rng), xy(rng), z(rng));
  return w;
}

// range(0) = number of waypoints including the start.
void BM_SolveMinSnap(benchmark::State& state) {
  const std::vector<Vec3> w = Waypoints(static_cast<int>(state.range(0)), 1);
  std::vector<double> durations_s;
  for (size_t i = 0; i + 1 < w.size(); ++i) {
    durations_s.push_back(RampSegmentTime((w[i + 1] - w[i]).norm(), {}));
  }
  for (auto _ : state) {
    auto traj = SolveMinSnap(w, durations_s, Vec3::Zero(), Vec3::Zero());
    benchmark::DoNotOptimize(traj);
  }
}
BENCHMARK(BM_SolveMinSnap)->Arg(3)->Arg(10)->Unit(benchmark::kMicrosecond);

// From rest (the replan-at-path-end case): one solve, one scaled re-solve,
// and the speed/acceleration maxima of both.
void BM_PlanMinSnap(benchmark::State& state) {
  const std::vector<Vec3> w = Waypoints(static_cast<int>(state.range(0)), 2);
  const StartState start{w[0], Vec3::Zero(), Vec3::Zero()};
  const std::vector<Vec3> rest(w.begin() + 1, w.end());
  for (auto _ : state) {
    auto traj = PlanMinSnap(start, rest, {});
    benchmark::DoNotOptimize(traj);
  }
}
BENCHMARK(BM_PlanMinSnap)->Arg(3)->Arg(10)->Unit(benchmark::kMicrosecond);

// Cruising at 2 m/s sideways: the scaling is no longer exact, so the
// fixed-point iteration takes a few more solves.
void BM_PlanMinSnapMoving(benchmark::State& state) {
  const std::vector<Vec3> w = Waypoints(static_cast<int>(state.range(0)), 2);
  const Vec3 towards = (w[1] - w[0]).normalized();
  const Vec3 sideways(-towards.y(), towards.x(), 0.0);
  const StartState start{w[0], 2.0 * sideways.normalized(), Vec3::Zero()};
  const std::vector<Vec3> rest(w.begin() + 1, w.end());
  if (!PlanMinSnap(start, rest, {}).ok()) state.SkipWithError("plan failed");
  for (auto _ : state) {
    auto traj = PlanMinSnap(start, rest, {});
    benchmark::DoNotOptimize(traj);
  }
}
BENCHMARK(BM_PlanMinSnapMoving)->Arg(3)->Arg(10)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace oaipp
