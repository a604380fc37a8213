#include "core/environment/esdf.h"

#include <cmath>
#include <random>

#include "core/environment/environment.h"
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
  std::int64_t smallest_update = env->esdf().values().size();
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
  ASSERT_EQ(fresh->values().size(), env->esdf().values().size());
  std::int64_t differing = 0;
  for (std::size_t i = 0; i < fresh->values().size(); ++i) {
    differing += fresh->values()[i] != env->esdf().values()[i];
  }
  EXPECT_EQ(differing, 0);
  // A small obstacle's update touched only part of the grid.
  EXPECT_LT(smallest_update, static_cast<std::int64_t>(fresh->values().size()) / 2);
}

TEST(EsdfTest, EmptyWorldIsTruncationEverywhere) {
  auto esdf = Esdf::Create(testing::E1Volume(), {.voxel_size_m = 0.5, .truncation_m = 2.0});
  ASSERT_TRUE(esdf.ok());
  esdf->Rebuild({});
  for (float v : esdf->values()) ASSERT_EQ(v, 2.0f);
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

// Each grid's values, copied out: what a reader of the grid sees.
std::vector<float> Values(const Environment& env) {
  return {env.esdf().values().begin(), env.esdf().values().end()};
}

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
  EXPECT_EQ(a.esdf().values().data(), b.esdf().values().data());
  EXPECT_NE(a.esdf().values().data(), other.esdf().values().data());
  EXPECT_EQ(a.esdf().SharedBy(), 2);
  EXPECT_EQ(pool.size(), 2);

  // A change to b copies its grid first: a still reads what it built.
  ASSERT_TRUE(b.Apply({.add = {{.id = "new", .shape = Box{{3, 3, 5}, {2, 2, 10}, 0.0}}}}).ok());
  EXPECT_NE(a.esdf().values().data(), b.esdf().values().data());
  EXPECT_EQ(Values(a), before);
  EXPECT_EQ(a.esdf().SharedBy(), 1);
  EXPECT_LT(b.esdf().Distance({3, 3, 5}), 0.0);
  EXPECT_GT(a.esdf().Distance({3, 3, 5}), 0.0);

  // A clone shares until it changes, too.
  Environment c = a.Clone();
  EXPECT_EQ(a.esdf().values().data(), c.esdf().values().data());
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
  ASSERT_EQ(a->esdf().values().size(), b->esdf().values().size());
  EXPECT_FALSE(a->ShareEsdf(pool));
  EXPECT_FALSE(b->ShareEsdf(pool));
  EXPECT_EQ(pool.size(), 2);
}

}  // namespace
}  // namespace oaipp
