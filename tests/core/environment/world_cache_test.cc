#include "core/environment/world_cache.h"

#include <atomic>
#include <thread>
#include <vector>

#include "core/common/status_macros.h"
#include "gtest/gtest.h"
#include "tests/core/environment/test_worlds.h"

namespace oaipp {
namespace {

absl::StatusOr<Environment> Build(unsigned seed, std::atomic<int>& builds) {
  ++builds;
  OAIPP_ASSIGN_OR_RETURN(Environment env,
                         Environment::Create(testing::E1Volume(), {.voxel_size_m = 0.5}));
  OAIPP_RETURN_IF_ERROR(env.Apply({.add = testing::RandomObstacles(seed, 4)}));
  return env;
}

TEST(WorldCacheTest, OneBuildPerKeyAndTheClonesShareTheGrid) {
  WorldCache cache(2);
  std::atomic<int> builds{0};
  // Eight at once for one key: built once, the others wait for it.
  std::vector<std::thread> threads;
  std::vector<Environment> got;
  absl::Mutex mu;
  for (int i = 0; i < 8; ++i) {
    threads.emplace_back([&] {
      absl::StatusOr<Environment> env = cache.Get("a", [&] { return Build(1, builds); });
      ASSERT_TRUE(env.ok());
      absl::MutexLock lock(&mu);
      got.push_back(*std::move(env));
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(builds.load(), 1);
  ASSERT_EQ(got.size(), 8u);
  for (const Environment& env : got) {
    EXPECT_EQ(env.esdf().grid_id(), got[0].esdf().grid_id());
    EXPECT_EQ(env.obstacles().size(), 4u);
  }
  // What a clone sees equals a world built directly.
  std::atomic<int> unused{0};
  const Environment direct = *Build(1, unused);
  EXPECT_TRUE(direct.esdf().SameValues(got[0].esdf()));
  EXPECT_EQ(direct.esdf().DenseValues(), got[0].esdf().DenseValues());
  // Changing one clone leaves the cached world alone.
  ASSERT_TRUE(got[0].Apply({.remove = {got[0].obstacles().begin()->first}}).ok());
  EXPECT_EQ(cache.Get("a", [&] { return Build(1, builds); })->obstacles().size(), 4u);
  EXPECT_EQ(builds.load(), 1);

  // Capacity 2: a third key drops the least recently used ("b").
  ASSERT_TRUE(cache.Get("b", [&] { return Build(2, builds); }).ok());
  ASSERT_TRUE(cache.Get("a", [&] { return Build(1, builds); }).ok());
  ASSERT_TRUE(cache.Get("c", [&] { return Build(3, builds); }).ok());
  EXPECT_EQ(builds.load(), 3);
  ASSERT_TRUE(cache.Get("a", [&] { return Build(1, builds); }).ok());
  EXPECT_EQ(builds.load(), 3);
  ASSERT_TRUE(cache.Get("b", [&] { return Build(2, builds); }).ok());
  EXPECT_EQ(builds.load(), 4);
  EXPECT_EQ(cache.builds(), 4);
}

TEST(WorldCacheTest, AFailedBuildIsNotRemembered) {
  WorldCache cache;
  int calls = 0;
  const auto failing = [&]() -> absl::StatusOr<Environment> {
    ++calls;
    return absl::InvalidArgumentError("spec.obstacles[0]: bad");
  };
  EXPECT_EQ(cache.Get("x", failing).status().message(), "spec.obstacles[0]: bad");
  EXPECT_EQ(cache.Get("x", failing).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(calls, 2);
}

}  // namespace
}  // namespace oaipp
