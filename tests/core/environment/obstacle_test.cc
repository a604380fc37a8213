#include "core/environment/obstacle.h"

#include <cmath>
#include <random>

#include "fcl/geometry/shape/box.h"
#include "fcl/geometry/shape/cylinder.h"
#include "fcl/geometry/shape/sphere.h"
#include "fcl/narrowphase/distance.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/environment/test_worlds.h"

namespace oaipp {
namespace {

// docs/reference-values.md: q = |p - c| - h per axis; outside |max(q, 0)|, inside max_i q_i.
TEST(ObstacleTest, BoxSignedDistanceFollowsReferenceFormula) {
  const Shape box = Box{{1, 2, 3}, {2, 4, 6}, 0.0};                          // half sizes (1, 2, 3)
  EXPECT_DOUBLE_EQ(SignedDistance(box, {4, 2, 3}), 2.0);                     // face
  EXPECT_DOUBLE_EQ(SignedDistance(box, {4, 6, 3}), std::sqrt(8.0));          // edge
  EXPECT_DOUBLE_EQ(SignedDistance(box, {4, 6, 8}), std::sqrt(4 + 4 + 4.0));  // corner
  EXPECT_DOUBLE_EQ(SignedDistance(box, {1, 2, 3}), -1.0);                    // centre
  EXPECT_DOUBLE_EQ(SignedDistance(box, {1.5, 2, 3}), -0.5);
}

TEST(ObstacleTest, YawRotatesTheBoxAboutItsCentre) {
  // A 10 x 2 box turned by 90 degrees extends 5 m along y, 1 m along x.
  const Shape box = Box{{0, 0, 1}, {10, 2, 2}, DegToRad(90)};
  EXPECT_NEAR(SignedDistance(box, {0, 6, 1}), 1.0, 1e-12);
  EXPECT_NEAR(SignedDistance(box, {3, 0, 1}), 2.0, 1e-12);
  const Aabb bb = BoundingBox(box);
  EXPECT_NEAR(bb.max_W.x(), 1.0, 1e-12);
  EXPECT_NEAR(bb.max_W.y(), 5.0, 1e-12);
}

TEST(ObstacleTest, CylinderSignedDistanceClosedForms) {
  const Shape cyl = Cylinder{{0, 0, 5}, 2.0, 10.0};
  EXPECT_DOUBLE_EQ(SignedDistance(cyl, {5, 0, 5}), 3.0);                  // side
  EXPECT_DOUBLE_EQ(SignedDistance(cyl, {0, 0, 12}), 2.0);                 // top
  EXPECT_DOUBLE_EQ(SignedDistance(cyl, {3, 4, 13}), std::sqrt(9 + 9.0));  // rim: (5-2, 13-10)
  EXPECT_DOUBLE_EQ(SignedDistance(cyl, {0, 0, 5}), -2.0);
}

// FCL is an independent implementation of the same geometry: its distance
// from a tiny sphere to each shape must match ours.
double FclDistance(const Shape& shape, const Vec3& p) {
  constexpr double kTiny = 1e-7;
  auto sphere = std::make_shared<fcl::Sphered>(kTiny);
  fcl::CollisionObjectd point(sphere, fcl::Transform3d(Eigen::Translation3d(p)));
  std::shared_ptr<fcl::CollisionGeometryd> geometry;
  fcl::Transform3d pose = fcl::Transform3d::Identity();
  if (const Box* box = std::get_if<Box>(&shape)) {
    geometry = std::make_shared<fcl::Boxd>(box->size_m);
    pose.translate(box->centre_W);
    pose.rotate(Eigen::AngleAxisd(box->yaw_rad, Eigen::Vector3d::UnitZ()));
  } else {
    const Cylinder& cyl = std::get<Cylinder>(shape);
    geometry = std::make_shared<fcl::Cylinderd>(cyl.radius_m, cyl.height_m);
    pose.translate(cyl.centre_W);
  }
  fcl::CollisionObjectd object(geometry, pose);
  fcl::DistanceRequestd request;
  request.enable_nearest_points = false;
  fcl::DistanceResultd result;
  fcl::distance(&point, &object, request, result);
  return result.min_distance + kTiny;
}

TEST(ObstacleTest, OutsideDistanceMatchesFclOnRandomWorlds) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coord(-20, 20), up(0, 30);
  int compared = 0;
  for (unsigned seed = 1; seed <= 5; ++seed) {
    for (const Obstacle& o : testing::RandomObstacles(seed, 10)) {
      for (int k = 0; k < 100; ++k) {
        const Vec3 p(coord(rng), coord(rng), up(rng));
        const double ours = SignedDistance(o.shape, p);
        if (ours < 1e-3) continue;  // FCL reports penetration differently
        EXPECT_NEAR(ours, FclDistance(o.shape, p), 1e-5) << o.id << " at " << p.transpose();
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 3000);
}

TEST(ObstacleTest, SegmentSignedDistanceMatchesDenseSampling) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> coord(-20, 20), up(0, 30);
  for (const Obstacle& o : testing::RandomObstacles(3, 12)) {
    for (int k = 0; k < 50; ++k) {
      const Vec3 a(coord(rng), coord(rng), up(rng)), b(coord(rng), coord(rng), up(rng));
      constexpr int kSamples = 20000;
      double sampled = std::numeric_limits<double>::infinity();
      for (int s = 0; s <= kSamples; ++s) {
        sampled = std::min(sampled, SignedDistance(o.shape, a + (b - a) * s / kSamples));
      }
      const double exact = SegmentSignedDistance(o.shape, a, b);
      // The minimum over samples can only be higher, by at most half a step.
      const double step = (b - a).norm() / kSamples;
      EXPECT_LE(exact, sampled + 1e-9);
      EXPECT_GE(exact, sampled - 0.5 * step - 1e-9);
    }
  }
}

TEST(ObstacleTest, SegmentHitsAgreesWithDenseInsideSampling) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> coord(-20, 20), up(0, 30);
  int hits = 0, misses = 0;
  for (const Obstacle& o : testing::RandomObstacles(9, 12)) {
    for (int k = 0; k < 200; ++k) {
      const Vec3 a(coord(rng), coord(rng), up(rng)), b(coord(rng), coord(rng), 0.0);
      constexpr int kSamples = 4000;
      bool sampled_inside = false;
      double closest = std::numeric_limits<double>::infinity();
      for (int s = 0; s <= kSamples; ++s) {
        const double d = SignedDistance(o.shape, a + (b - a) * s / kSamples);
        sampled_inside |= d < 0.0;
        closest = std::min(closest, std::abs(d));
      }
      const bool hit = SegmentHits(o.shape, a, b);
      // Only a graze within one sample step may disagree.
      if (hit != sampled_inside) {
        EXPECT_LT(closest, (b - a).norm() / kSamples) << o.id;
      }
      (hit ? hits : misses)++;
    }
  }
  EXPECT_GT(hits, 100);
  EXPECT_GT(misses, 100);
}

TEST(ObstacleTest, ValidationNamesTheField) {
  const absl::Status zero = ValidateObstacle({"flat", Box{{0, 0, 0}, {1, 0, 1}, 0}});
  EXPECT_EQ(zero.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(zero.message(), ::testing::HasSubstr("size_m[1]"));
  const absl::Status nan = ValidateObstacle({"nan", Cylinder{{0, NAN, 0}, 1, 1}});
  EXPECT_THAT(nan.message(), ::testing::HasSubstr("centre_W"));
  EXPECT_THAT(ValidateObstacle({"", Cylinder{}}).message(), ::testing::HasSubstr("id"));
  EXPECT_THAT(ValidateObstacle({"r", Cylinder{{0, 0, 0}, -1, 1}}).message(),
              ::testing::HasSubstr("radius_m"));
}

}  // namespace
}  // namespace oaipp
