#include "core/environment/environment.h"

#include <random>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/environment/test_worlds.h"

namespace oaipp {
namespace {

using ::testing::HasSubstr;

Obstacle E1Building() { return {"building", Box{{0, -1, 13}, {10, 4, 26}, 0.0}}; }

TEST(EnvironmentTest, ChangesAreAtomicAndErrorsNameTheCause) {
  auto env = Environment::Create(testing::E1Volume());
  ASSERT_TRUE(env.ok());
  ASSERT_TRUE(env->Apply({.add = {E1Building()}}).ok());
  const std::vector<float> before = env->esdf().DenseValues();

  const absl::Status dup = env->Apply({.add = {{"new", Cylinder{{5, 5, 2}, 1, 4}}, E1Building()}});
  EXPECT_EQ(dup.code(), absl::StatusCode::kAlreadyExists);
  EXPECT_THAT(dup.message(), HasSubstr("building"));
  const absl::Status unknown = env->Apply({.remove = {"nope"}});
  EXPECT_EQ(unknown.code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(env->Apply({.replace = {{"nope", Cylinder{}}}}).code(), absl::StatusCode::kNotFound);
  const absl::Status twice = env->Apply({.remove = {"building"}, .replace = {E1Building()}});
  EXPECT_EQ(twice.code(), absl::StatusCode::kInvalidArgument);
  const absl::Status bad = env->Apply(
      {.add = {{"ok", Cylinder{{1, 1, 1}, 1, 2}}, {"flat", Box{{0, 0, 0}, {0, 1, 1}, 0}}}});
  EXPECT_EQ(bad.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad.message(), HasSubstr("flat"));

  // None of the failed changes touched anything.
  EXPECT_EQ(env->obstacles().size(), 1u);
  EXPECT_EQ(env->esdf().DenseValues(), before);
}

TEST(EnvironmentTest, CollisionFollowsHalfUavRadius) {
  auto env = Environment::Create(testing::E1Volume());
  ASSERT_TRUE(env.ok());
  ASSERT_TRUE(env->Apply({.add = {E1Building()}}).ok());
  // Building face at x = 5. r_uav = 1 m: collision closer than 0.5 m.
  EXPECT_TRUE(env->InCollision({5.2, 0, 10}, 1.0));
  EXPECT_FALSE(env->InCollision({6.0, 0, 10}, 1.0));
  EXPECT_TRUE(env->InCollision({0, 0, 10}, 1.0));
  EXPECT_DOUBLE_EQ(env->SignedDistance({7, -1, 10}), 2.0);
}

TEST(EnvironmentTest, SegmentClearanceAgainstDenseSampling) {
  auto env = Environment::Create(testing::E1Volume(), {.voxel_size_m = 0.5});
  ASSERT_TRUE(env.ok());
  ASSERT_TRUE(env->Apply({.add = testing::RandomObstacles(21, 10)}).ok());
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> xy(-15, 15), z(0, 26), clearance(0.0, 1.5);
  int clear = 0, blocked = 0;
  for (int n = 0; n < 300; ++n) {
    const Vec3 a(xy(rng), xy(rng), z(rng)), b(xy(rng), xy(rng), z(rng));
    const double c = clearance(rng);
    constexpr int kSamples = 5000;
    double sampled = std::numeric_limits<double>::infinity();
    for (int s = 0; s <= kSamples; ++s) {
      sampled = std::min(sampled, env->SignedDistance(a + (b - a) * s / kSamples));
    }
    const double step = (b - a).norm() / kSamples;
    if (std::abs(sampled - c) < step) continue;  // too close to call by sampling
    EXPECT_EQ(env->IsSegmentClear(a, b, c), sampled > c) << "clearance " << c;
    EXPECT_NEAR(env->SegmentClearance(a, b), sampled, step);
    (sampled > c ? clear : blocked)++;
  }
  EXPECT_GT(clear, 50);
  EXPECT_GT(blocked, 50);
}

// Visibility of ground cells against a brute-force ray sampler.
TEST(EnvironmentTest, VisibilityMatchesBruteForceRaySampler) {
  auto env = Environment::Create(testing::E1Volume(), {.voxel_size_m = 0.5});
  ASSERT_TRUE(env.ok());
  ASSERT_TRUE(env->Apply({.add = testing::RandomObstacles(8, 15)}).ok());
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> xy(-15, 15), z(2, 26);
  int seen = 0, hidden = 0;
  for (int cam = 0; cam < 10; ++cam) {
    const Vec3 camera(xy(rng), xy(rng), z(rng));
    if (env->IsInsideObstacle(camera)) continue;
    std::vector<Vec3> ground;
    for (double x = -14.625; x < 15; x += 0.75) {
      for (double y = -14.625; y < 15; y += 0.75) ground.emplace_back(x, y, 0.0);
    }
    const std::vector<bool> visible = env->VisibleFrom(camera, ground);
    for (std::size_t i = 0; i < ground.size(); ++i) {
      constexpr int kSamples = 2000;
      bool blocked_by_sample = false;
      double closest = std::numeric_limits<double>::infinity();
      for (int s = 1; s <= kSamples; ++s) {
        const double d = env->SignedDistance(camera + (ground[i] - camera) * s / kSamples);
        blocked_by_sample |= d < 0.0;
        closest = std::min(closest, std::abs(d));
      }
      if (visible[i] == blocked_by_sample) {
        // Only a graze finer than the sampling may disagree.
        EXPECT_LT(closest, (ground[i] - camera).norm() / kSamples);
      }
      (visible[i] ? seen : hidden)++;
    }
  }
  EXPECT_GT(seen, 1000);
  EXPECT_GT(hidden, 200);
}

TEST(EnvironmentTest, GroundUnderABuildingIsNeverVisible) {
  auto env = Environment::Create(testing::E1Volume());
  ASSERT_TRUE(env.ok());
  ASSERT_TRUE(env->Apply({.add = {E1Building()}}).ok());
  EXPECT_FALSE(env->IsVisible({0, -1, 30}, {0, -1, 0}));
  EXPECT_TRUE(env->IsVisible({10, 0, 7}, {10, 5, 0}));
  // Behind the building seen from the side.
  EXPECT_FALSE(env->IsVisible({10, -1, 7}, {-10, -1, 0}));
}

TEST(EnvironmentTest, EmptyWorldAnswersSanely) {
  auto env = Environment::Create(testing::E1Volume());
  ASSERT_TRUE(env.ok());
  EXPECT_TRUE(std::isinf(env->SignedDistance({0, 0, 0})));
  EXPECT_TRUE(env->IsSegmentClear({-15, -15, 0}, {15, 15, 26}, 5.0));
  EXPECT_TRUE(env->IsVisible({0, 0, 10}, {3, 3, 0}));
  EXPECT_FALSE(env->InCollision({0, 0, 10}, 1.0));
  // An empty change is fine and changes nothing.
  EXPECT_TRUE(env->Apply({}).ok());
}

TEST(EnvironmentTest, CloneIsIndependent) {
  auto env = Environment::Create(testing::E1Volume(), {.voxel_size_m = 0.5});
  ASSERT_TRUE(env.ok());
  Environment copy = env->Clone();
  ASSERT_TRUE(copy.Apply({.add = {E1Building()}}).ok());
  EXPECT_TRUE(env->obstacles().empty());
  EXPECT_FALSE(env->InCollision({0, -1, 10}, 1.0));
  EXPECT_TRUE(copy.InCollision({0, -1, 10}, 1.0));
}

}  // namespace
}  // namespace oaipp
