// ESDF build and update times on the paper's E1 world (docs/method.md §10):
// 30 x 30 x 26 m volume, one 4 x 10 x 26 m building; on a large field
// (BM_EsdfBuildLargeField): 300 x 300 x 40 m with 50 seeded buildings of
// 8-25 m sides and 6-35 m heights; and on a square kilometre
// (BM_EsdfBuildSquareKm): 1000 x 1000 x 60 m with 300 seeded prism
// buildings (SquareKmBuildings: houses, halls) at the default 0.2 m voxel.
//
//   build/tests/bench/environment/environment_bench --benchmark_repetitions=5
#include <benchmark/benchmark.h>

#include <sys/resource.h>
#include <random>
#include <string>
#include <vector>

#include "core/environment/environment.h"
#include "core/environment/prism.h"

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
    benchmark::DoNotOptimize(esdf->grid_id());
  }
  state.counters["voxels"] =
      static_cast<double>(esdf->dims()[0]) * esdf->dims()[1] * esdf->dims()[2];
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
  (void)env->Apply({.add = {block}});
  state.counters["recomputed_fraction"] =
      static_cast<double>(env->esdf().last_recomputed_voxels()) /
      static_cast<double>(Esdf::VoxelCount(kVolume, {.voxel_size_m = 0.2}));
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
    benchmark::DoNotOptimize(esdf->grid_id());
  }
  state.counters["voxels"] =
      static_cast<double>(esdf->dims()[0]) * esdf->dims()[1] * esdf->dims()[2];
  state.counters["grid_mb"] = static_cast<double>(esdf->MemoryBytes()) / (1 << 20);
  state.SetLabel(std::to_string(voxel_m) + " m voxels");
}
BENCHMARK(BM_EsdfBuildLargeField)->Arg(50)->Arg(20)->Unit(benchmark::kMillisecond)->Iterations(1);

// 300 buildings over a square kilometre, as a suburb's map data has them:
// three in four houses (7-16 m sides, 3-10 m tall), the rest halls and
// blocks (15-40 m sides, 6-20 m tall); rotated rectangles and L shapes.
std::vector<Shape> SquareKmBuildings() {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> xy(-480, 480), yaw(0, 3.14), coin(0, 1);
  std::uniform_real_distribution<double> house_side(7, 16), house_height(3, 10);
  std::uniform_real_distribution<double> hall_side(15, 40), hall_height(6, 20);
  std::vector<Shape> buildings;
  while (buildings.size() < 300) {
    const bool house = coin(rng) < 0.75;
    const double a = house ? house_side(rng) : hall_side(rng);
    const double b = house ? house_side(rng) : hall_side(rng);
    const double h = house ? house_height(rng) : hall_height(rng);
    const double t = yaw(rng);
    const Vec2 c(xy(rng), xy(rng));
    std::vector<Vec2> local = {{0, 0}, {a, 0}, {a, b}, {0, b}};
    if (coin(rng) < 0.4)
      local = {{0, 0}, {a, 0}, {a, 0.4 * b}, {0.4 * a, 0.4 * b}, {0.4 * a, b}, {0, b}};
    std::vector<Vec2> footprint;
    for (const Vec2& p : local) {
      const Vec2 q = p - Vec2(0.5 * a, 0.5 * b);
      footprint.push_back(c + Vec2(std::cos(t) * q.x() - std::sin(t) * q.y(),
                                   std::sin(t) * q.x() + std::cos(t) * q.y()));
    }
    absl::StatusOr<Prism> prism = Prism::Create(footprint, 0.0, h);
    if (prism.ok()) buildings.push_back(*prism);
  }
  return buildings;
}

// Building the grid for the square kilometre, and what it holds: the peak
// resident memory of the whole process is reported too.
void BM_EsdfBuildSquareKm(benchmark::State& state) {
  const Aabb volume{{-500, -500, 0}, {500, 500, 60}};
  const std::vector<Shape> buildings = SquareKmBuildings();
  std::vector<const Shape*> shapes;
  for (const Shape& b : buildings) shapes.push_back(&b);
  absl::StatusOr<Esdf> esdf = Esdf::Create(volume, {});
  if (!esdf.ok()) {
    state.SkipWithError(std::string(esdf.status().message()).c_str());
    return;
  }
  for (auto _ : state) {
    esdf->Rebuild(shapes);
    benchmark::DoNotOptimize(esdf->grid_id());
  }
  state.counters["voxels_spanned"] = static_cast<double>(Esdf::VoxelCount(volume, {}));
  state.counters["blocks_held"] = static_cast<double>(esdf->allocated_blocks());
  state.counters["grid_mb"] = static_cast<double>(esdf->MemoryBytes()) / (1 << 20);
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  state.counters["peak_rss_mb"] = static_cast<double>(usage.ru_maxrss) / 1024.0;
}
BENCHMARK(BM_EsdfBuildSquareKm)->Unit(benchmark::kMillisecond)->Iterations(1);

// Distance lookups on the square kilometre, at random points of the volume
// (most in free space) and next to buildings.
void BM_EsdfLookupSquareKm(benchmark::State& state) {
  const Aabb volume{{-500, -500, 0}, {500, 500, 60}};
  const std::vector<Shape> buildings = SquareKmBuildings();
  std::vector<const Shape*> shapes;
  for (const Shape& b : buildings) shapes.push_back(&b);
  absl::StatusOr<Esdf> esdf = Esdf::Create(volume, {});
  esdf->Rebuild(shapes);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> xy(-500, 500), z(0, 60), near(-3, 3);
  std::vector<Vec3> points;
  for (int n = 0; n < 4096; ++n) {
    if (state.range(0) == 0) {
      points.emplace_back(xy(rng), xy(rng), z(rng));
    } else {
      const Aabb box = BoundingBox(buildings[n % buildings.size()]);
      points.push_back(box.max_W + Vec3(near(rng), near(rng), near(rng) - 3));
    }
  }
  std::size_t n = 0;
  for (auto _ : state) {
    Vec3 g;
    benchmark::DoNotOptimize(esdf->DistanceAndGradient(points[n++ % points.size()], &g));
  }
  state.SetLabel(state.range(0) == 0 ? "anywhere" : "near buildings");
}
BENCHMARK(BM_EsdfLookupSquareKm)->Arg(0)->Arg(1);

}  // namespace
}  // namespace oaipp
