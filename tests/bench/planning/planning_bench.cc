// Planner benchmarks (issue: the OA-IPP planner and its baselines).
//
//   build/tests/bench/planning/planning_bench --benchmark_repetitions=5
//     (add --benchmark_report_aggregates_only=true for medians only)
//
// - BM_ObjectiveSpeedup: the fast objective against the plain reference
//   (sequential full Kalman updates on a copy), same run, same paths; the
//   `speedup` counter is the ratio of evaluation rates.
// - BM_ReplanE1: full OA-IPP replans on the E1 world (1600 cells, N = 3,
//   12 x 45 = 540 CMA-ES evaluations after the greedy start), one thread,
//   from eight start states, as oaipp-server plans by default (OpenBLAS,
//   the objective's solves in single precision); median and worst replan
//   time (BM_ReplanE1/server_defaults:1). server_defaults:0: on Eigen in double precision
//   (the planner's own defaults, which the tests pin).
// - BM_ReplanScaling: the same replan for N = 3, 5, 8 waypoints and square
//   fields of 20 to 60 m at 0.75 m cells.
// - BM_MovingAgainstRest: E1 replans through MakePlanner (so with the stop
//   first of docs/method.md §7.7) from the eight starts at rest and from the
//   same places moving (seeded: 1 to 5 m/s, up to 3 m/s^2, any direction),
//   alternating; `moving_over_rest` is the ratio of the medians.
// - BM_ConfirmationAgainstPaper: the BM_ReplanE1 replans with the paper's
//   objective and with the confirmation term (weight 100), alternating;
//   `confirm_over_paper` is the ratio of the medians.
// - BM_SinglePrecisionAgainstDouble: the BM_ReplanE1 replans on OpenBLAS
//   with the objective's solves in double and in single precision,
//   alternating; `single_over_double` is the ratio of the medians,
//   `same_paths` the share of plans identical bit for bit.
// - BM_LawnmowerFromRest: the lawnmower at rest from 6 places (where clear)
//   in E3's worlds of 5, 10 and 15 low- and high-rise buildings, seeds 1 to
//   60; counts the starts, the answers and those flown stop and go (the
//   last resort where no smooth route passes the exact check).
// - BM_PastDeadline/objective/side: OA-IPP (0 adaptive, 1 trace) asked for a
//   plan whose deadline has already passed, on a side x side m field at
//   0.75 m cells; `answer_ms` is the median time to its anytime answer over
//   5 calls, `eval_ms` the median of one full evaluation of a one-waypoint
//   path, `answered` the calls that returned a path.
// - BM_WayHome/buildings: PlanWayHome (core/planning/return_home.h) across
//   a 200 x 200 m field of that many random buildings (5-15 m wide, 10-60 m
//   tall under a 40 m ceiling), from 8 seeded rest points to a home in a
//   corner; `median_ms` and `max_ms` per way home, `found` of 8.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/mapping/dense_backend.h"
#include "core/planning/planners.h"
#include "tests/core/planning/scenes.h"

namespace oaipp {
namespace {

struct World {
  std::unique_ptr<Environment> env;
  std::unique_ptr<GpMap> map;
  PlanningContext View() const { return {env.get(), map.get(), DownwardCamera{}, SensorNoise{}}; }
};

// A field of side_m x side_m at 0.75 m cells with the E1 building scaled to
// its centre-south, 26 m ceiling.
World MakeWorld(double side_m) {
  const double h = side_m / 2;
  World w;
  auto env = Environment::Create({{-h, -h, 2}, {h, h, 26}}, {.voxel_size_m = 0.2});
  (void)env->Apply({.add = {{"building", Box{{0, -1, 13}, {10, 4, 26}, 0.0}}}});
  w.env = std::make_unique<Environment>(std::move(env).value());
  auto grid = FieldGrid::FromBounds({-h, -h}, {h, h}, 0.75);
  auto map = GpMap::Create(*grid, GpParams::PaperPreset(0.75));
  w.map = std::make_unique<GpMap>(std::move(map).value());
  const std::vector<int> covered =
      grid->CellsUnderObstacles([&](const Vec3& p_W) { return w.env->IsInsideObstacle(p_W); });
  (void)w.map->FuseNearCertainZeros(covered);
  return w;
}

// The middle element (the upper one of an even count).
double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

const World& E1() {
  static const World* world = new World(MakeWorld(30.0));
  return *world;
}

// Measurement poses of seeded random candidate paths over E1: 1-3 shots at
// altitudes 3-25 m, as CMA-ES candidates produce them.
std::vector<std::vector<PoseObservation>> CandidatePaths(int count) {
  const World& w = E1();
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> xy(-14, 14), z(3, 25);
  std::uniform_int_distribution<int> shots(1, 3);
  const DownwardCamera camera;
  const SensorNoise noise;
  std::vector<std::vector<PoseObservation>> paths;
  for (int i = 0; i < count; ++i) {
    std::vector<PoseObservation> poses;
    for (int s = shots(rng); s > 0; --s) {
      const Vec3 p(xy(rng), xy(rng), z(rng));
      poses.push_back({camera.VisibleFootprintCells(w.map->grid(), p, w.env.get()),
                       noise.Variance(p.z()), p.z(), true});
    }
    paths.push_back(std::move(poses));
  }
  return paths;
}

void BM_ObjectiveSpeedup(benchmark::State& state) {
  const InformationParams params{.kind = state.range(0) == 0 ? ObjectiveKind::kAdaptive
                                                             : ObjectiveKind::kNonAdaptive};
  const World& w = E1();
  const auto paths = CandidatePaths(40);
  const InformationEvaluator fast(w.map->Mean(), w.map->Covariance(), params);
  // The non-adaptive cache of P^2 is built once per map, after the first
  // evaluations (InformationEvaluator::UseBaseSquared): time the steady state.
  for (const auto& p : paths) (void)fast.Evaluate(p);
  double fast_s = 0, reference_s = 0, checksum = 0;
  for (auto _ : state) {
    auto t0 = std::chrono::steady_clock::now();
    for (const auto& p : paths) checksum += fast.Evaluate(p);
    auto t1 = std::chrono::steady_clock::now();
    for (const auto& p : paths)
      checksum -= ReferenceInformation(w.map->Mean(), w.map->Covariance(), params, p);
    auto t2 = std::chrono::steady_clock::now();
    fast_s += std::chrono::duration<double>(t1 - t0).count();
    reference_s += std::chrono::duration<double>(t2 - t1).count();
    state.SetIterationTime(std::chrono::duration<double>(t1 - t0).count());
  }
  benchmark::DoNotOptimize(checksum);
  const double evals = static_cast<double>(state.iterations()) * paths.size();
  state.counters["fast_evals_per_s"] = evals / fast_s;
  state.counters["reference_evals_per_s"] = evals / reference_s;
  state.counters["speedup"] = reference_s / fast_s;
  state.SetLabel(params.kind == ObjectiveKind::kAdaptive ? "adaptive" : "non-adaptive");
}
BENCHMARK(BM_ObjectiveSpeedup)
    ->Arg(0)
    ->Arg(1)
    ->UseManualTime()
    ->Iterations(3)
    ->Unit(benchmark::kMillisecond);

void Replan(benchmark::State& state, const World& w, int waypoints) {
  OaIppConfig config;
  config.num_waypoints = waypoints;
  UavState start;
  start.position_W = Vec3(10, 0, 7);
  std::int64_t evaluations = 0;
  for (auto _ : state) {
    OaIppPlanner planner(PlannerCommon{}, config);
    auto path = planner.Plan(w.View(), start, absl::InfiniteFuture());
    if (!path.ok()) state.SkipWithError(std::string(path.status().message()).c_str());
    evaluations = path->stats.evaluations;
  }
  state.counters["evaluations"] = static_cast<double>(evaluations);
  state.counters["cells"] = w.map->num_cells();
}

// One replan's cost depends on the path it finds (longer paths carry more
// shots), so E1 replans from eight start states spread over the field and
// reports the median and the worst of all plans.
void BM_ReplanE1(benchmark::State& state) {
  const bool server_defaults = state.range(0) == 1;
  PlannerCommon common;
  if (server_defaults) {
    // ServerOptions: --dense_backend=openblas, --objective_precision=single.
    const absl::StatusOr<DenseBackend> blas = DenseBackend::OpenBlas();
    if (!blas.ok()) {
      state.SkipWithError(std::string(blas.status().message()).c_str());
      return;
    }
    common.information.dense_backend = *blas;
    common.information.single_precision = true;
    state.SetLabel(blas->name() + ", single precision");
  }
  const World& w = E1();
  const std::vector<Vec3> starts = {{10, 0, 7},    {-10, 8, 10}, {5, 10, 12},  {-12, -12, 8},
                                    {12, -10, 15}, {0, 6, 5},    {-6, -5, 18}, {8, 8, 20}};
  std::vector<double> seconds;
  std::int64_t evaluations = 0;
  for (auto _ : state) {
    for (const Vec3& p : starts) {
      OaIppPlanner planner(common, OaIppConfig{});
      UavState start;
      start.position_W = p;
      const auto t0 = std::chrono::steady_clock::now();
      auto path = planner.Plan(w.View(), start, absl::InfiniteFuture());
      seconds.push_back(
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      if (!path.ok()) state.SkipWithError(std::string(path.status().message()).c_str());
      evaluations += path->stats.evaluations;
    }
  }
  std::sort(seconds.begin(), seconds.end());
  state.counters["median_replan_ms"] = 1e3 * seconds[seconds.size() / 2];
  state.counters["max_replan_ms"] = 1e3 * seconds.back();
  state.counters["evaluations_per_plan"] = static_cast<double>(evaluations) / seconds.size();
}
BENCHMARK(BM_ReplanE1)
    ->ArgName("server_defaults")
    ->Arg(1)
    ->Arg(0)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2);

// The confirmation objective's cost (docs/method.md §6.4): the same E1
// replans as BM_ReplanE1 with the paper's objective and with the
// confirmation term at weight 100 (as in the README's experiments),
// alternating; `confirm_over_paper` is the ratio of the medians.
void BM_ConfirmationAgainstPaper(benchmark::State& state) {
  const World& w = E1();
  const std::vector<Vec3> starts = {{10, 0, 7},    {-10, 8, 10}, {5, 10, 12},  {-12, -12, 8},
                                    {12, -10, 15}, {0, 6, 5},    {-6, -5, 18}, {8, 8, 20}};
  std::vector<double> paper_s, confirm_s;
  for (auto _ : state) {
    for (const Vec3& p : starts) {
      for (const double weight : {0.0, 100.0}) {
        PlannerCommon common;
        common.information.confirmation_weight = weight;
        OaIppPlanner planner(common, OaIppConfig{});
        UavState start;
        start.position_W = p;
        const auto t0 = std::chrono::steady_clock::now();
        auto path = planner.Plan(w.View(), start, absl::InfiniteFuture());
        (weight > 0 ? confirm_s : paper_s)
            .push_back(
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        if (!path.ok()) state.SkipWithError(std::string(path.status().message()).c_str());
      }
    }
  }
  state.counters["paper_median_ms"] = 1e3 * Median(paper_s);
  state.counters["confirm_median_ms"] = 1e3 * Median(confirm_s);
  state.counters["confirm_over_paper"] = Median(confirm_s) / Median(paper_s);
}
BENCHMARK(BM_ConfirmationAgainstPaper)->Unit(benchmark::kMillisecond)->Iterations(2);

// Single-precision objective solves (InformationParams::single_precision) against
// double, on OpenBLAS as the server runs them: the BM_ReplanE1 replans,
// alternating; `single_over_double` is the ratio of the medians and
// `same_paths` the share of plans whose waypoints came out bit for bit
// those of double precision.
void BM_SinglePrecisionAgainstDouble(benchmark::State& state) {
  const absl::StatusOr<DenseBackend> blas = DenseBackend::OpenBlas();
  if (!blas.ok()) {
    state.SkipWithError(std::string(blas.status().message()).c_str());
    return;
  }
  const std::string backend = blas->name();
  const World& w = E1();
  const std::vector<Vec3> starts = {{10, 0, 7},    {-10, 8, 10}, {5, 10, 12},  {-12, -12, 8},
                                    {12, -10, 15}, {0, 6, 5},    {-6, -5, 18}, {8, 8, 20}};
  std::vector<double> double_s, single_s;
  int same = 0, plans = 0;
  for (auto _ : state) {
    for (const Vec3& p : starts) {
      std::vector<Vec3> waypoints[2];
      for (const bool single : {false, true}) {
        PlannerCommon common;
        common.information.single_precision = single;
        common.information.dense_backend = *blas;
        OaIppPlanner planner(common, OaIppConfig{});
        UavState start;
        start.position_W = p;
        const auto t0 = std::chrono::steady_clock::now();
        auto path = planner.Plan(w.View(), start, absl::InfiniteFuture());
        (single ? single_s : double_s)
            .push_back(
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        if (!path.ok()) {
          state.SkipWithError(std::string(path.status().message()).c_str());
          return;
        }
        waypoints[single ? 1 : 0] = path->control_waypoints_W;
      }
      same += waypoints[0] == waypoints[1] ? 1 : 0;
      ++plans;
    }
  }
  if (plans == 0) return;
  state.counters["double_median_ms"] = 1e3 * Median(double_s);
  state.counters["single_median_ms"] = 1e3 * Median(single_s);
  state.counters["single_over_double"] = Median(single_s) / Median(double_s);
  state.counters["same_paths"] = static_cast<double>(same) / plans;
  state.SetLabel(backend);
}
BENCHMARK(BM_SinglePrecisionAgainstDouble)->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_LawnmowerFromRest(benchmark::State& state) {
  const std::vector<Vec3> places = {{-5.193, -10.852, 8}, {-5.193, -10.852, 15},
                                    {5, 10, 8},           {-10, 3, 12},
                                    {0, 0, 20},           {12, -12, 5}};
  int starts = 0, answered = 0, stop_and_go = 0;
  for (auto _ : state) {
    for (bool high_rise : {false, true}) {
      for (int count : {5, 10, 15}) {
        for (unsigned seed = 1; seed <= 60; ++seed) {
          const testing::Scene scene = testing::RandomWorld(seed, count, high_rise);
          for (const Vec3& p : places) {
            if (scene.env->SignedDistance(p) < 1.0) continue;
            UavState start;
            start.position_W = p;
            PlannerConfig config{.kind = PlannerKind::kLawnmower};
            config.common.seed = seed;
            auto planner = MakePlanner(config);
            ++starts;
            auto path = (*planner)->Plan(scene.View(), start, absl::InfiniteFuture());
            if (!path.ok()) continue;
            ++answered;
            if (path->stats.stop_reason == "pattern_stop_and_go") ++stop_and_go;
          }
        }
      }
    }
  }
  state.counters["starts"] = starts;
  state.counters["answered"] = answered;
  state.counters["stop_and_go"] = stop_and_go;
}
BENCHMARK(BM_LawnmowerFromRest)->Unit(benchmark::kSecond)->Iterations(1);

void BM_PastDeadline(benchmark::State& state) {
  static std::map<int, World>* worlds = new std::map<int, World>();
  const int side = static_cast<int>(state.range(1));
  if (!worlds->contains(side)) worlds->emplace(side, MakeWorld(side));
  const World& w = worlds->at(side);
  PlannerConfig config{.kind = state.range(0) == 0 ? PlannerKind::kOaIpp
                                                   : PlannerKind::kOaIppNonAdaptive};
  UavState start;
  start.position_W = Vec3(side / 3.0, 0, 7);
  std::vector<double> answer_s, eval_s;
  int answered = 0;
  for (auto _ : state) {
    for (int k = 0; k < 5; ++k) {
      auto planner = MakePlanner(config);
      const auto t0 = std::chrono::steady_clock::now();
      auto path = (*planner)->Plan(w.View(), start, absl::Now());
      answer_s.push_back(
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      if (path.ok()) ++answered;
    }
    // One evaluation as CMA-ES makes it, on a scorer already built.
    PlannerCommon common = config.common;
    common.information.kind = config.kind == PlannerKind::kOaIppNonAdaptive
                                  ? ObjectiveKind::kNonAdaptive
                                  : ObjectiveKind::kAdaptive;
    auto scorer = PathScorer::Create(w.View(), start, common);
    if (!scorer.ok()) {
      state.SkipWithError(std::string(scorer.status().message()).c_str());
      break;
    }
    for (int k = 0; k < 5; ++k) {
      const auto t0 = std::chrono::steady_clock::now();
      benchmark::DoNotOptimize(scorer->Score({Vec3(-side / 4.0, -side / 4.0 + k, 15)}));
      eval_s.push_back(
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
  }
  state.counters["answer_ms"] = 1e3 * Median(answer_s);
  state.counters["eval_ms"] = 1e3 * Median(eval_s);
  state.counters["answered"] = answered;
}
BENCHMARK(BM_PastDeadline)
    ->ArgsProduct({{0, 1}, {30, 60}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

void BM_MovingAgainstRest(benchmark::State& state) {
  const World& w = E1();
  const std::vector<Vec3> places = {{10, 0, 7},    {-10, 8, 10}, {5, 10, 12},  {-12, -12, 8},
                                    {12, -10, 15}, {0, 6, 5},    {-6, -5, 18}, {8, 8, 20}};
  std::mt19937_64 rng(15);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<double> rest_s, moving_s;
  int stopped_first = 0, refused = 0;
  auto time_plan = [&](const UavState& start, std::vector<double>* out) {
    auto planner = MakePlanner(PlannerConfig{});
    const auto t0 = std::chrono::steady_clock::now();
    auto path = (*planner)->Plan(w.View(), start, absl::InfiniteFuture());
    out->push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    if (!path.ok()) {
      ++refused;
    } else if (path->stats.stop_first_s > 0) {
      ++stopped_first;
    }
  };
  for (auto _ : state) {
    for (const Vec3& p : places) {
      UavState rest;
      rest.position_W = p;
      time_plan(rest, &rest_s);
      UavState moving = rest;
      moving.velocity_W_m_s = Vec3(g(rng), g(rng), g(rng)).normalized() * (1 + 4 * u(rng));
      moving.accel_W_m_s2 = Vec3(g(rng), g(rng), g(rng)).normalized() * (3 * u(rng));
      time_plan(moving, &moving_s);
    }
  }
  state.counters["rest_median_ms"] = 1e3 * Median(rest_s);
  state.counters["moving_median_ms"] = 1e3 * Median(moving_s);
  state.counters["moving_over_rest"] = Median(moving_s) / Median(rest_s);
  state.counters["stopped_first"] = stopped_first;
  state.counters["refused"] = refused;
}
BENCHMARK(BM_MovingAgainstRest)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_ReplanScaling(benchmark::State& state) {
  static std::map<int, World>* worlds = new std::map<int, World>();
  const int side = static_cast<int>(state.range(1));
  if (!worlds->contains(side)) worlds->emplace(side, MakeWorld(side));
  Replan(state, worlds->at(side), static_cast<int>(state.range(0)));
}
void BM_WayHome(benchmark::State& state) {
  const int buildings = static_cast<int>(state.range(0));
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> xy(-90.0, 90.0), size(5.0, 15.0), height(10.0, 60.0);
  std::vector<Obstacle> obstacles;
  const Vec3 home(-95, -95, 10);
  for (int i = 0; static_cast<int>(obstacles.size()) < buildings && i < 100 * buildings; ++i) {
    const double h = height(rng);
    Box box{.centre_W = {xy(rng), xy(rng), 0.5 * h}, .size_m = {size(rng), size(rng), h}};
    if ((box.centre_W.head<2>() - home.head<2>()).norm() < 20.0) continue;
    obstacles.push_back({absl::StrCat("b", i), box});
  }
  absl::StatusOr<Environment> env =
      Environment::Create({{-100, -100, 2}, {100, 100, 40}}, {.voxel_size_m = 1.0});
  if (!env.ok() || !env->Apply({.add = obstacles}).ok()) {
    state.SkipWithError("world");
    return;
  }
  PlannerLimits limits;
  limits.obstacle_rule = PlannerLimits::ObstacleRule::kBody;
  std::vector<UavState> starts;
  std::uniform_real_distribution<double> far(20.0, 95.0);
  while (starts.size() < 8) {
    const Vec3 p(far(rng), far(rng), 10 + 10 * (starts.size() % 3));
    if (env->SignedDistance(p) > 3.0) starts.push_back({.position_W = p});
  }
  std::vector<double> seconds;
  int found = 0;
  for (auto _ : state) {
    for (const UavState& start : starts) {
      const auto t0 = std::chrono::steady_clock::now();
      absl::StatusOr<WayHome> back = PlanWayHome(*env, start, home, limits);
      seconds.push_back(
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      found += back.ok() ? 1 : 0;
    }
  }
  state.counters["median_ms"] = 1e3 * Median(seconds);
  state.counters["max_ms"] = 1e3 * *std::max_element(seconds.begin(), seconds.end());
  state.counters["found"] = found / static_cast<double>(state.iterations());
}
BENCHMARK(BM_WayHome)
    ->ArgName("buildings")
    ->Arg(10)
    ->Arg(100)
    ->Arg(300)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

BENCHMARK(BM_ReplanScaling)
    ->ArgNames({"waypoints", "field_m"})
    ->Args({3, 30})
    ->Args({5, 30})
    ->Args({8, 30})
    ->Args({3, 21})
    ->Args({3, 45})
    ->Args({3, 60})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);

}  // namespace
}  // namespace oaipp
