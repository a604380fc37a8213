#include "core/mapping/prior_cache.h"

#include <memory>
#include <thread>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace oaipp {
namespace {

using ::testing::HasSubstr;

FieldGrid Grid(const Vec2& origin, int nx, int ny, double resolution_m) {
  auto grid = FieldGrid::Create(origin, nx, ny, resolution_m);
  EXPECT_TRUE(grid.ok()) << grid.status();
  return *grid;
}

TEST(PriorCacheTest, SharedPriorEqualsAFreshOneBitForBit) {
  PriorCache cache;
  const FieldGrid grid = Grid(Vec2(-15, -15), 40, 40, 0.75);
  const GpParams params = GpParams::PaperPreset(0.75);
  auto cached = cache.NewMap(grid, params);
  auto fresh = GpMap::Create(grid, params);
  ASSERT_TRUE(cached.ok() && fresh.ok());
  EXPECT_TRUE(cached->Covariance() == fresh->Covariance());
  EXPECT_TRUE(cached->Mean() == fresh->Mean());
  EXPECT_NEAR(cached->Trace(), 387.319924, 5e-6);  // docs/reference-values.md
  // A second map shares the prior and is independent of the first.
  const std::vector<CellObservation> shot = {{.cell = 5, .value = 1.0, .variance = 0.4}};
  ASSERT_TRUE(cached->Update(shot).ok());
  auto second = cache.NewMap(grid, params);
  ASSERT_TRUE(second.ok());
  EXPECT_TRUE(second->Covariance() == fresh->Covariance());
  EXPECT_EQ(cache.computations(), 1);
}

TEST(PriorCacheTest, KeyIsShapeAndKernelNotOriginOrPriorMean) {
  PriorCache cache;
  const GpParams params = GpParams::PaperPreset(1.0);
  auto a = cache.Get(Grid(Vec2(0, 0), 8, 6, 1.0), params);
  GpParams other_mean = params;
  other_mean.prior_mean = 0.3;
  auto b = cache.Get(Grid(Vec2(-40, 7), 8, 6, 1.0), other_mean);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->get(), b->get());
  EXPECT_EQ(cache.computations(), 1);
  // Any change of shape or kernel is another prior.
  GpParams longer = params;
  longer.length_scale_m *= 1.5;
  GpParams noisier = params;
  noisier.noise_var *= 2;
  GpParams stronger = params;
  stronger.signal_var *= 2;
  for (const auto& [grid, p] :
       std::vector<std::pair<FieldGrid, GpParams>>{{Grid(Vec2(0, 0), 6, 8, 1.0), params},
                                                   {Grid(Vec2(0, 0), 8, 6, 0.5), params},
                                                   {Grid(Vec2(0, 0), 8, 6, 1.0), longer},
                                                   {Grid(Vec2(0, 0), 8, 6, 1.0), noisier},
                                                   {Grid(Vec2(0, 0), 8, 6, 1.0), stronger}}) {
    auto c = cache.Get(grid, p);
    ASSERT_TRUE(c.ok());
    EXPECT_NE(c->get(), a->get());
    auto direct = PriorCovariance(grid, p);
    ASSERT_TRUE(direct.ok());
    EXPECT_TRUE(**c == *direct);
  }
  EXPECT_EQ(cache.computations(), 6);
}

TEST(PriorCacheTest, DropsTheLeastRecentlyUsedBeyondCapacity) {
  PriorCache cache(2);
  const GpParams params = GpParams::PaperPreset(1.0);
  const FieldGrid g1 = Grid(Vec2(0, 0), 5, 5, 1.0), g2 = Grid(Vec2(0, 0), 6, 5, 1.0),
                  g3 = Grid(Vec2(0, 0), 7, 5, 1.0);
  ASSERT_TRUE(cache.Get(g1, params).ok());
  ASSERT_TRUE(cache.Get(g2, params).ok());
  ASSERT_TRUE(cache.Get(g1, params).ok());  // g1 is now the most recent
  ASSERT_TRUE(cache.Get(g3, params).ok());  // drops g2
  EXPECT_EQ(cache.size(), 2);
  EXPECT_EQ(cache.computations(), 3);
  ASSERT_TRUE(cache.Get(g1, params).ok());
  EXPECT_EQ(cache.computations(), 3);
  ASSERT_TRUE(cache.Get(g2, params).ok());
  EXPECT_EQ(cache.computations(), 4);
  // A prior handed out stays valid after it is dropped.
  auto held = cache.Get(g3, params);
  ASSERT_TRUE(held.ok());
  ASSERT_TRUE(cache.Get(g1, params).ok());
  EXPECT_EQ((*held)->rows(), 35);
}

TEST(PriorCacheTest, ConcurrentFirstRequestsComputeOnce) {
  PriorCache cache;
  const FieldGrid grid = Grid(Vec2(0, 0), 20, 20, 0.75);
  const GpParams params = GpParams::PaperPreset(0.75);
  std::vector<std::shared_ptr<const Eigen::MatrixXd>> got(8);
  std::vector<std::thread> threads;
  for (int i = 0; i < 8; ++i) {
    threads.emplace_back([&, i] {
      auto p = cache.Get(grid, params);
      if (p.ok()) got[static_cast<std::size_t>(i)] = *p;
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(cache.computations(), 1);
  for (const auto& p : got) {
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(p.get(), got[0].get());
  }
}

TEST(PriorCacheTest, ErrorsNameTheFieldAndAreNotKept) {
  PriorCache cache;
  GpParams bad = GpParams::PaperPreset(1.0);
  bad.length_scale_m = -1;
  auto map = cache.NewMap(Grid(Vec2(0, 0), 4, 4, 1.0), bad);
  EXPECT_EQ(map.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(map.status().message(), HasSubstr("length_scale_m"));
  auto prior = cache.Get(Grid(Vec2(0, 0), 4, 4, 1.0), bad);
  EXPECT_EQ(prior.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(cache.size(), 0);
}

}  // namespace
}  // namespace oaipp
