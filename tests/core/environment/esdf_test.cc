#include "core/environment/esdf.h"

#include <cmath>
#include <random>

#include "core/environment/environment.h"
#include "core/environment/prism.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/environment/test_worlds.h"

namespace oaipp {
namespace {

Environment MakeWorld(unsigned seed, int count, double voxel_m = 0.2) {
  auto env = Environment::Create(testing::E1Volume(), {.voxel_size_m = voxel_m});
  EXPECT_TRUE(env.ok()) << env.status();
  EXPECT_TRUE(env->Apply({.add = testing::RandomObstacles(seed, count)}).ok());
  return std::move(env).value();
}

double Clamped(double d, double trunc) { return std::clamp(d, -trunc, trunc); }

// Where obstacles overlap, the minimum of their own signed distances is not
// the distance to the union's surface (part of each surface is buried in the
// other). The exact reference is used only where it is exact: outside every
// obstacle, or inside one that overlaps no other.
bool ReferenceIsExact(const Environment& env, const Vec3& p) {
  int inside = 0;
  const Obstacle* container = nullptr;
  for (const auto& [id, o] : env.obstacles()) {
    if (SignedDistance(o.shape, p) < 0) {
      ++inside;
      container = &o;
    }
  }
  if (inside == 0) return true;
  if (inside > 1) return false;
  const Aabb box = BoundingBox(container->shape);
  for (const auto& [id, o] : env.obstacles()) {
    if (&o != container && BoundingBox(o.shape).Intersects(box)) return false;
  }
  return true;
}

class EsdfAccuracyTest : public ::testing::TestWithParam<std::tuple<unsigned, int>> {};

// docs/method.md §2: every voxel value is within half a voxel diagonal of the
// exact (truncated) signed distance.
TEST_P(EsdfAccuracyTest, VoxelCentresWithinHalfDiagonalOfExactDistance) {
  const auto [seed, count] = GetParam();
  const Environment env = MakeWorld(seed, count);
  const Esdf& esdf = env.esdf();
  const double half_diag = 0.5 * std::sqrt(3.0) * esdf.voxel_size_m();
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> ix(0, esdf.dims()[0] - 1), iy(0, esdf.dims()[1] - 1),
      iz(0, esdf.dims()[2] - 1);
  double worst = 0.0;
  int compared = 0;
  for (int n = 0; n < 20000; ++n) {
    const int i = ix(rng), j = iy(rng), k = iz(rng);
    const Vec3 centre = esdf.VoxelCentre(i, j, k);
    if (!env.flight_volume().Contains(centre) || !ReferenceIsExact(env, centre)) continue;
    ++compared;
    const double exact = Clamped(env.SignedDistance(esdf.VoxelCentre(i, j, k)), 2.0);
    worst = std::max(worst, std::abs(esdf.Value(i, j, k) - exact));
  }
  EXPECT_LE(worst, half_diag + 1e-5);
  EXPECT_GT(compared, 8000);
}

// Between voxel centres the trilinear interpolant of a 1-Lipschitz field
// adds at most another half diagonal.
TEST_P(EsdfAccuracyTest, InterpolatedWithinOneDiagonalAtRandomPoints) {
  const auto [seed, count] = GetParam();
  const Environment env = MakeWorld(seed, count);
  const double diag = std::sqrt(3.0) * env.esdf().voxel_size_m();
  std::mt19937 rng(100 + seed);
  std::uniform_real_distribution<double> xy(-15, 15), z(0, 26);
  double worst = 0.0, sum = 0.0;
  int compared = 0;
  constexpr int kPoints = 5000;
  for (int n = 0; n < kPoints; ++n) {
    const Vec3 p(xy(rng), xy(rng), z(rng));
    // Interpolation mixes corner values: all eight corners need an exact
    // reference, so stay a voxel away from overlaps.
    if (!ReferenceIsExact(env, p) || env.SignedDistance(p) < 0) continue;
    ++compared;
    const double err = std::abs(env.esdf().Distance(p) - Clamped(env.SignedDistance(p), 2.0));
    worst = std::max(worst, err);
    sum += err;
  }
  EXPECT_LE(worst, diag + 1e-5);
  EXPECT_GT(compared, 3500);
  EXPECT_LT(sum / compared, 0.05);  // and small on average
}

INSTANTIATE_TEST_SUITE_P(RandomWorlds, EsdfAccuracyTest,
                         ::testing::Values(std::make_tuple(1u, 5), std::make_tuple(2u, 10),
                                           std::make_tuple(3u, 15)));

// A concave prism (an L-shaped building): its voxels too lie within half a
// voxel diagonal of its exact signed distance, in the notch as elsewhere.
TEST(EsdfTest, AConcavePrismsVoxelsFollowItsExactDistance) {
  auto env = Environment::Create(testing::E1Volume(), {.voxel_size_m = 0.25});
  ASSERT_TRUE(env.ok()) << env.status();
  absl::StatusOr<Prism> hall =
      Prism::Create({{-10, -10}, {6, -10}, {6, -4}, {-4, -4}, {-4, 8}, {-10, 8}}, 0.0, 14.0);
  ASSERT_TRUE(hall.ok()) << hall.status();
  ASSERT_TRUE(env->Apply({.add = {{"hall", *hall}}}).ok());
  const Esdf& esdf = env->esdf();
  const double half_diag = 0.5 * std::sqrt(3.0) * esdf.voxel_size_m();
  std::mt19937 rng(8);
  std::uniform_int_distribution<int> ix(0, esdf.dims()[0] - 1), iy(0, esdf.dims()[1] - 1),
      iz(0, esdf.dims()[2] - 1);
  double worst = 0.0;
  int in_notch = 0;
  for (int n = 0; n < 20000; ++n) {
    const int i = ix(rng), j = iy(rng), k = iz(rng);
    const Vec3 centre = esdf.VoxelCentre(i, j, k);
    if (!env->flight_volume().Contains(centre)) continue;
    const double exact = Clamped(hall->SignedDistance(centre), 2.0);
    worst = std::max(worst, std::abs(esdf.Value(i, j, k) - exact));
    in_notch += centre.x() > -4 && centre.x() < 0 && centre.y() > -4 && centre.y() < 0;
  }
  EXPECT_LE(worst, half_diag + 1e-5);
  EXPECT_GT(in_notch, 100);
}

TEST(EsdfTest, IncrementalUpdatesEqualAFullRebuild) {
  auto env = Environment::Create(testing::E1Volume(), {.voxel_size_m = 0.25});
  ASSERT_TRUE(env.ok());
  const std::vector<Obstacle> obstacles = testing::RandomObstacles(42, 12);
  // Add one by one, then replace two, then remove three.
  const std::int64_t all_voxels = Esdf::VoxelCount(testing::E1Volume(), {.voxel_size_m = 0.25});
  std::int64_t smallest_update = all_voxels;
  for (const Obstacle& o : obstacles) {
    ASSERT_TRUE(env->Apply({.add = {o}}).ok());
    smallest_update = std::min(smallest_update, env->esdf().last_recomputed_voxels());
  }
  Obstacle moved = obstacles[3];
  moved.shape = Box{{2, 3, 4}, {1, 2, 8}, 0.3};
  Obstacle grown = obstacles[7];
  grown.shape = Cylinder{{-9, 9, 6}, 1.5, 12};
  ASSERT_TRUE(env->Apply({.replace = {moved, grown}}).ok());
  ASSERT_TRUE(env->Apply({.remove = {obstacles[0].id, obstacles[5].id, obstacles[9].id}}).ok());

  std::vector<const Shape*> shapes;
  for (const auto& [id, o] : env->obstacles()) shapes.push_back(&o.shape);
  auto fresh = Esdf::Create(testing::E1Volume(), {.voxel_size_m = 0.25});
  ASSERT_TRUE(fresh.ok());
  fresh->Rebuild(shapes);
  const std::vector<float> want = fresh->DenseValues();
  const std::vector<float> got = env->esdf().DenseValues();
  ASSERT_EQ(want.size(), got.size());
  std::int64_t differing = 0;
  for (std::size_t i = 0; i < want.size(); ++i) differing += want[i] != got[i];
  EXPECT_EQ(differing, 0);
  EXPECT_TRUE(fresh->SameValues(env->esdf()));
  // A small obstacle's update touched only part of the grid.
  EXPECT_LT(smallest_update, all_voxels / 2);
}

TEST(EsdfTest, EmptyWorldIsTruncationEverywhere) {
  auto esdf = Esdf::Create(testing::E1Volume(), {.voxel_size_m = 0.5, .truncation_m = 2.0});
  ASSERT_TRUE(esdf.ok());
  esdf->Rebuild({});
  for (float v : esdf->DenseValues()) ASSERT_EQ(v, 2.0f);
  EXPECT_EQ(esdf->allocated_blocks(), 0);
  EXPECT_DOUBLE_EQ(esdf->Distance({0, 0, 10}), 2.0);
}

// An obstacle just outside the flight volume still shapes the field at the
// volume's edge (the grid is padded by the truncation distance).
TEST(EsdfTest, ObstacleJustOutsideTheVolumeIsSeen) {
  auto env = Environment::Create(testing::E1Volume(), {.voxel_size_m = 0.2});
  ASSERT_TRUE(env.ok());
  ASSERT_TRUE(env->Apply({.add = {{"outside", Box{{16.0, 0, 5}, {1, 1, 10}, 0}}}}).ok());
  // Box face at x = 15.5; the point (15, 0, 5) is 0.5 m from it.
  EXPECT_NEAR(env->esdf().Distance({15, 0, 5}), 0.5, 0.2);
  ASSERT_TRUE(env->Apply({.add = {{"far", Box{{100, 0, 5}, {1, 1, 10}, 0}}}}).ok());
  EXPECT_NEAR(env->esdf().Distance({0, 0, 5}), 2.0, 1e-6);
}

TEST(EsdfTest, GradientPointsAwayFromTheWall) {
  //   y
  //   ^   |####|      wall: x in [-1, 1], tall
  //   |   |####|  p   p = (3, 0, 5): gradient ~ +x
  //   +------------> x
  auto env = Environment::Create(testing::E1Volume(), {.voxel_size_m = 0.2});
  ASSERT_TRUE(env.ok());
  ASSERT_TRUE(env->Apply({.add = {{"wall", Box{{0, 0, 13}, {2, 20, 26}, 0}}}}).ok());
  Vec3 g;
  const double d = env->esdf().DistanceAndGradient({2.05, 0.05, 5.05}, &g);
  EXPECT_NEAR(d, 1.05, 0.18);
  EXPECT_NEAR(g.x(), 1.0, 0.05);
  EXPECT_NEAR(g.y(), 0.0, 0.05);
}

TEST(EsdfTest, BadConfigurationsAreRefused) {
  EXPECT_EQ(Esdf::Create(testing::E1Volume(), {.voxel_size_m = 0}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(
      Esdf::Create(testing::E1Volume(), {.voxel_size_m = 0.2, .truncation_m = NAN}).status().code(),
      absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Esdf::Create({{0, 0, 0}, {0, 1, 1}}, {}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Esdf::Create(testing::E1Volume(), {.voxel_size_m = 0.01, .max_voxels = 1000000})
                .status()
                .code(),
            absl::StatusCode::kResourceExhausted);
}

// Memory follows the obstacles, not the volume: a square kilometre at the
// default 0.2 m voxel (5.5e9 voxels spanned) holds only the blocks around its
// buildings, and its values there follow the exact distance as a small
// grid's do.
TEST(EsdfTest, ASquareKilometreHoldsOnlyTheBlocksAroundItsBuildings) {
  const Aabb volume{{-500, -500, 0}, {500, 500, 40}};
  auto env = Environment::Create(volume);
  ASSERT_TRUE(env.ok()) << env.status();
  absl::StatusOr<Prism> hall = Prism::Create(
      {{300, 300}, {316, 300}, {316, 306}, {306, 306}, {306, 318}, {300, 318}}, 0.0, 12.0);
  ASSERT_TRUE(hall.ok());
  const std::vector<Obstacle> buildings = {{"house", Box{{-200, 100, 4}, {10, 12, 8}, 0.4}},
                                           {"hall", *hall},
                                           {"mast", Cylinder{{0, -450, 15}, 1.0, 30}}};
  ASSERT_TRUE(env->Apply({.add = buildings}).ok());
  const Esdf& esdf = env->esdf();
  EXPECT_GT(Esdf::VoxelCount(volume, {}), 5'000'000'000);
  // Each building's surroundings: at most its bounding box grown by the
  // truncation and a block on every side, in blocks of 8^3 voxels.
  double bound_m3 = 0.0;
  for (const Obstacle& o : buildings) {
    const Vec3 size = BoundingBox(o.shape).Size() + Vec3::Constant(2 * (2.0 + 1.6 + 0.4));
    bound_m3 += size.prod();
  }
  const double block_m3 = std::pow(8 * 0.2, 3);
  EXPECT_GT(esdf.allocated_blocks(), 0);
  EXPECT_LE(esdf.allocated_blocks(), bound_m3 / block_m3);
  // The bound used for admission holds what was allocated.
  std::vector<const Shape*> shapes;
  for (const auto& [id, o] : env->obstacles()) shapes.push_back(&o.shape);
  EXPECT_GE(esdf.HeldVoxelBound(shapes), esdf.allocated_blocks() * Esdf::kBlockVoxels);
  // Values near each building, against the exact distance.
  const double half_diag = 0.5 * std::sqrt(3.0) * esdf.voxel_size_m();
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> off(-4, 4);
  double worst = 0.0;
  for (const Obstacle& o : buildings) {
    const Aabb box = BoundingBox(o.shape);
    for (int n = 0; n < 3000; ++n) {
      const Vec3 p =
          0.5 * (box.min_W + box.max_W) +
          Vec3(0.5 * box.Size().x() + off(rng), off(rng), 0.0).cwiseProduct(Vec3(1, 1, 0)) +
          Vec3(0, 0, std::clamp(off(rng) + 4, 0.5, 39.0));
      const Vec3 c = (p - esdf.origin_W()) / esdf.voxel_size_m();
      const int i = static_cast<int>(c.x()), j = static_cast<int>(c.y()),
                k = static_cast<int>(c.z());
      const double exact = Clamped(SignedDistance(o.shape, esdf.VoxelCentre(i, j, k)), 2.0);
      worst = std::max(worst, std::abs(esdf.Value(i, j, k) - exact));
    }
  }
  EXPECT_LE(worst, half_diag + 1e-5);
  // Far from every building: free space, no block held.
  EXPECT_EQ(esdf.Distance({100, -100, 20}), 2.0);
}

// The grid is built by tiles on several threads; the values do not depend
// on how many.
TEST(EsdfTest, ValuesDoNotDependOnTheBuildThreads) {
  std::vector<Obstacle> obstacles = testing::RandomObstacles(9, 12);
  auto one = Environment::Create(testing::E1Volume(), {.build_threads = 1});
  auto three = Environment::Create(testing::E1Volume(), {.build_threads = 3});
  ASSERT_TRUE(one.ok() && three.ok());
  ASSERT_TRUE(one->Apply({.add = obstacles}).ok());
  ASSERT_TRUE(three->Apply({.add = obstacles}).ok());
  EXPECT_TRUE(one->esdf().SameValues(three->esdf()));
  EXPECT_EQ(one->esdf().DenseValues(), three->esdf().DenseValues());
  EXPECT_EQ(Environment::Create(testing::E1Volume(), {.build_threads = 0}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// An obstacle set whose surroundings would need more voxels than the limit
// is refused, naming the obstacles, and nothing changes.
TEST(EsdfTest, ObstaclesBeyondTheVoxelLimitAreRefused) {
  auto env = Environment::Create(testing::E1Volume(), {.max_voxels = 400'000});
  ASSERT_TRUE(env.ok()) << env.status();
  ASSERT_TRUE(env->Apply({.add = {{"small", Box{{0, 0, 2}, {1, 1, 4}, 0}}}}).ok());
  const std::vector<float> before = env->esdf().DenseValues();
  const absl::Status big = env->Apply({.add = {{"wall", Box{{5, 0, 13}, {1, 28, 26}, 0}}}});
  EXPECT_EQ(big.code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(big.message()), ::testing::StartsWith("obstacles:"));
  EXPECT_EQ(env->obstacles().size(), 1u);
  EXPECT_EQ(env->esdf().DenseValues(), before);
}

// Each grid's values, copied out: what a reader of the grid sees.
std::vector<float> Values(const Environment& env) { return env.esdf().DenseValues(); }

TEST(EsdfPoolTest, EqualWorldsShareOneGridAndChangesCopyIt) {
  EsdfPool pool;
  Environment a = MakeWorld(7, 5, 0.5);
  Environment b = MakeWorld(7, 5, 0.5);
  Environment other = MakeWorld(8, 5, 0.5);
  const std::vector<float> before = Values(a);
  EXPECT_FALSE(a.ShareEsdf(pool));  // the first of its kind
  EXPECT_TRUE(b.ShareEsdf(pool));
  EXPECT_FALSE(other.ShareEsdf(pool));
  EXPECT_FALSE(a.ShareEsdf(pool));  // already the pooled grid
  EXPECT_EQ(a.esdf().grid_id(), b.esdf().grid_id());
  EXPECT_NE(a.esdf().grid_id(), other.esdf().grid_id());
  EXPECT_EQ(a.esdf().SharedBy(), 2);
  EXPECT_EQ(pool.size(), 2);

  // A change to b copies its grid first: a still reads what it built.
  ASSERT_TRUE(b.Apply({.add = {{.id = "new", .shape = Box{{3, 3, 5}, {2, 2, 10}, 0.0}}}}).ok());
  EXPECT_NE(a.esdf().grid_id(), b.esdf().grid_id());
  EXPECT_EQ(Values(a), before);
  EXPECT_EQ(a.esdf().SharedBy(), 1);
  EXPECT_LT(b.esdf().Distance({3, 3, 5}), 0.0);
  EXPECT_GT(a.esdf().Distance({3, 3, 5}), 0.0);

  // A clone shares until it changes, too.
  Environment c = a.Clone();
  EXPECT_EQ(a.esdf().grid_id(), c.esdf().grid_id());
  ASSERT_TRUE(c.Apply({.remove = {a.obstacles().begin()->first}}).ok());
  EXPECT_EQ(Values(a), before);

  // Grids nobody holds leave the pool.
  { Environment gone = std::move(other); }
  EXPECT_EQ(pool.size(), 1);
}

TEST(EsdfPoolTest, GridsOfEqualValuesButAnotherPlaceAreNotShared) {
  EsdfPool pool;
  // Two empty worlds hold the same values (truncation everywhere) over
  // different volumes of one size.
  auto a = Environment::Create({{0, 0, 2}, {10, 10, 12}}, {.voxel_size_m = 0.5});
  auto b = Environment::Create({{5, 0, 2}, {15, 10, 12}}, {.voxel_size_m = 0.5});
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a->esdf().DenseValues(), b->esdf().DenseValues());
  EXPECT_FALSE(a->ShareEsdf(pool));
  EXPECT_FALSE(b->ShareEsdf(pool));
  EXPECT_EQ(pool.size(), 2);
}

}  // namespace
}  // namespace oaipp
