// The closed airspace (core/environment/airspace.h) against numbers from
// outside it: closed forms on a square and an L-shaped fence, a densely
// sampled boundary and a winding-number inside test for random star-shaped
// fences, dense sampling along segments, and in the Environment: the fence
// and a zone count for clearance, never for line of sight.
#include "core/environment/airspace.h"

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include "core/environment/environment.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace oaipp {
namespace {

using ::testing::HasSubstr;

Airspace FenceOnly(std::vector<Vec2> ring) {
  absl::StatusOr<Airspace> air = Airspace::Create(Fence{.polygon_W = std::move(ring)}, {});
  EXPECT_TRUE(air.ok()) << air.status();
  return *std::move(air);
}

TEST(AirspaceTest, AnLShapedFenceHasItsClosedForms) {
  // [0, 20] x [0, 8] and [0, 8] x [8, 20], given clockwise.
  const Airspace air = FenceOnly({{0, 20}, {8, 20}, {8, 8}, {20, 8}, {20, 0}, {0, 0}});
  EXPECT_DOUBLE_EQ(air.SignedDistance({4, 4, 30}), 4.0);     // at any altitude
  EXPECT_DOUBLE_EQ(air.SignedDistance({15, 5, 10}), 3.0);    // the east arm's north wall
  EXPECT_DOUBLE_EQ(air.SignedDistance({10, 10, 10}), -2.0);  // in the notch, 2 m off
  EXPECT_DOUBLE_EQ(air.SignedDistance({11, 11, 10}), -3.0);  // both arms 3 m off
  EXPECT_DOUBLE_EQ(air.SignedDistance({25, 4, 10}), -5.0);   // east of the fence
  EXPECT_DOUBLE_EQ(air.SignedDistance({23, 11, 10}), -std::hypot(3.0, 3.0));  // off a corner
  EXPECT_TRUE(air.zones().empty());
  ASSERT_TRUE(air.fence().has_value());
  EXPECT_EQ(air.fence()->polygon_W.front(), Vec2(0, 0));  // stored counter-clockwise
  EXPECT_EQ(air.fence()->polygon_W[1], Vec2(20, 0));
}

TEST(AirspaceTest, ACircleFenceAndItsSegments) {
  const Airspace air = *Airspace::Create(Fence{.centre_W = {5, -5}, .radius_m = 10}, {});
  EXPECT_DOUBLE_EQ(air.SignedDistance({5, -5, 3}), 10.0);
  EXPECT_DOUBLE_EQ(air.SignedDistance({5, 8, 3}), -3.0);
  // Along a chord the distance to the circle is least at an end.
  EXPECT_DOUBLE_EQ(air.SegmentSignedDistance({0, -5, 3}, {5, 3, 9}), 2.0);
  EXPECT_LE(air.SegmentSignedDistance({0, -5, 3}, {5, 8, 9}), 0.0);
}

// The test's own distance from p to the ring's boundary (each edge sampled
// every 1 mm) and inside test (winding number).
double SampledFenceDistance(const std::vector<Vec2>& ring, const Vec2& p) {
  double nearest = std::numeric_limits<double>::infinity();
  double winding = 0.0;
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const Vec2& a = ring[i];
    const Vec2& b = ring[(i + 1) % ring.size()];
    const int steps = static_cast<int>((b - a).norm() / 1e-3) + 1;
    for (int k = 0; k <= steps; ++k) {
      nearest = std::min(nearest, (a + (b - a) * (double(k) / steps) - p).norm());
    }
    const Vec2 u = a - p, v = b - p;
    winding += std::atan2(u.x() * v.y() - u.y() * v.x(), u.dot(v));
  }
  const bool inside = std::abs(winding) > std::numbers::pi;
  return inside ? nearest : -nearest;
}

std::vector<Vec2> RandomStarFence(std::mt19937& rng) {
  std::uniform_real_distribution<double> radius(6.0, 14.0);
  std::vector<Vec2> ring;
  const int n = 5 + static_cast<int>(rng() % 8);
  for (int k = 0; k < n; ++k) {
    const double a = 2.0 * std::numbers::pi * k / n;
    const double r = radius(rng);
    ring.emplace_back(r * std::cos(a), r * std::sin(a));
  }
  return ring;
}

TEST(AirspaceTest, RandomConcaveFencesAgreeWithASampledBoundary) {
  std::mt19937 rng(2303);
  std::uniform_real_distribution<double> xy(-16.0, 16.0), z(0.0, 30.0);
  for (int trial = 0; trial < 20; ++trial) {
    const std::vector<Vec2> ring = RandomStarFence(rng);
    const Airspace air = FenceOnly(ring);
    for (int k = 0; k < 40; ++k) {
      const Vec3 p(xy(rng), xy(rng), z(rng));
      EXPECT_NEAR(air.SignedDistance(p), SampledFenceDistance(ring, p.head<2>()), 1e-3)
          << trial << " " << p.transpose();
    }
  }
}

// Along random segments: the segment's value is the least of the values
// sampled along it (to the sampling's reach) where the segment stays inside,
// and <= 0 where it leaves.
TEST(AirspaceTest, SegmentDistanceIsTheLeastAlongTheSegment) {
  std::mt19937 rng(75);
  std::uniform_real_distribution<double> xy(-12.0, 12.0), z(0.0, 30.0);
  int inside = 0, leaving = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const std::vector<Vec2> ring = RandomStarFence(rng);
    // A cylinder zone with a floor, and the fence.
    const Obstacle zone{"z", Cylinder{{xy(rng) / 3, xy(rng) / 3, 15}, 2.0, 10.0}};
    const Airspace air = *Airspace::Create(Fence{.polygon_W = ring}, {zone});
    for (int k = 0; k < 20; ++k) {
      const Vec3 a(xy(rng), xy(rng), z(rng)), b(xy(rng), xy(rng), z(rng));
      double sampled = std::numeric_limits<double>::infinity();
      constexpr int kSteps = 4000;
      for (int s = 0; s <= kSteps; ++s) {
        sampled = std::min(sampled, air.SignedDistance(a + (b - a) * (double(s) / kSteps)));
      }
      const double exact = air.SegmentSignedDistance(a, b);
      if (sampled > 0.0) {
        ++inside;
        // Sampling finds the least to within half a step's length.
        EXPECT_LE(exact, sampled + 1e-12);
        EXPECT_GE(exact, sampled - 0.5 * (b - a).norm() / kSteps - 1e-9);
      } else {
        ++leaving;
        EXPECT_LE(exact, 0.0);
      }
    }
  }
  EXPECT_GT(inside, 50);
  EXPECT_GT(leaving, 50);
}

TEST(AirspaceTest, BadFencesAndZonesAreRefusedNamingTheField) {
  const auto refused = [](std::optional<Fence> fence, std::vector<Obstacle> zones) {
    return Airspace::Create(std::move(fence), std::move(zones), "spec.fence.polygon",
                            "spec.no_fly_zones")
        .status();
  };
  // A bow tie: edges 0 and 2 cross.
  absl::Status s = refused(Fence{.polygon_W = {{0, 0}, {10, 10}, {10, 0}, {0, 10}}}, {});
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("spec.fence.polygon: edges 0 and 2 cross"));
  s = refused(Fence{.polygon_W = {{0, 0}, {1, 1}}}, {});
  EXPECT_THAT(s.message(), HasSubstr("spec.fence.polygon: needs at least 3"));
  s = refused(Fence{.centre_W = {0, 0}, .radius_m = 0.0}, {});
  EXPECT_THAT(s.message(), HasSubstr(".radius_m: must be positive"));
  s = refused(Fence{.centre_W = {NAN, 0}, .radius_m = 3.0}, {});
  EXPECT_THAT(s.message(), HasSubstr(".centre: must be finite"));
  const Obstacle zone{"tower", Cylinder{{0, 0, 5}, 2.0, 10.0}};
  s = refused(std::nullopt, {zone, zone});
  EXPECT_THAT(s.message(), HasSubstr("spec.no_fly_zones[1].id: named twice"));
  s = refused(std::nullopt, {Obstacle{"", Cylinder{}}});
  EXPECT_THAT(s.message(), HasSubstr("spec.no_fly_zones[0].id: must not be empty"));
  s = refused(std::nullopt, {Obstacle{"flat", Cylinder{{0, 0, 5}, 2.0, 0.0}}});
  EXPECT_THAT(s.message(), HasSubstr("spec.no_fly_zones[0]"));
  EXPECT_TRUE(Airspace::Create(std::nullopt, {}).ok());
  EXPECT_TRUE(Airspace::Create(std::nullopt, {})->empty());
}

// In the world: the fence and a zone count for every clearance query, the
// ESDF's included (without an obstacle, whose ESDF is empty), and hide
// nothing from the camera; a clone keeps them.
TEST(AirspaceTest, TheEnvironmentKeepsClearOfTheAirspaceButSeesThroughIt) {
  absl::StatusOr<Environment> env =
      Environment::Create({{-20, -20, 0}, {20, 20, 30}}, {.voxel_size_m = 0.5});
  ASSERT_TRUE(env.ok());
  const Obstacle zone{"stadium", Cylinder{{0, 0, 20}, 3.0, 10.0}};  // floor 15 m, ceiling 25 m
  env->SetAirspace(
      *Airspace::Create(Fence{.polygon_W = {{-10, -10}, {10, -10}, {10, 10}, {-10, 10}}}, {zone}));
  const Environment copy = env->Clone();
  const Environment* const both[] = {&*env, &copy};
  for (const Environment* e : both) {
    EXPECT_DOUBLE_EQ(e->SignedDistance({9, 0, 5}), 1.0);    // the fence's east side
    EXPECT_DOUBLE_EQ(e->SignedDistance({0, 0, 12}), 3.0);   // under the zone's floor
    EXPECT_DOUBLE_EQ(e->SignedDistance({0, 0, 20}), -3.0);  // in it
    EXPECT_TRUE(e->CloserThan({9.5, 0, 5}, 1.0));
    EXPECT_FALSE(e->CloserThan({5, 5, 5}, 1.0));
    EXPECT_TRUE(e->InCollision({0, 0, 14}, 3.0));  // 1 m under the floor, r / 2 = 1.5
    EXPECT_FALSE(e->IsSegmentClear({-5, 5, 5}, {15, 5, 5}, 0.5));   // leaves the fence
    EXPECT_FALSE(e->IsSegmentClear({-5, 0, 20}, {5, 0, 20}, 0.5));  // through the zone
    EXPECT_TRUE(e->IsSegmentClear({-5, 0, 10}, {5, 0, 10}, 0.5));   // under it
    EXPECT_NEAR(e->SegmentClearance({-5, 0, 10}, {5, 0, 10}), 5.0, 1e-9);
    EXPECT_FALSE(e->IsInsideObstacle({0, 0, 20}));      // a zone is no solid
    EXPECT_FALSE(e->IsInsideObstacle({15, 0, 5}));      // nor is outside the fence
    EXPECT_TRUE(e->IsVisible({0, 0, 28}, {0, 0, 0}));   // down through the zone
    EXPECT_TRUE(e->IsVisible({0, 0, 5}, {15, 15, 0}));  // out past the fence
    EXPECT_FALSE(e->airspace().empty());
  }
}

}  // namespace
}  // namespace oaipp
