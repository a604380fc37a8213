// Prisms (core/environment/prism.h) against numbers from outside them:
// closed forms on an L-shaped building, FCL's distances to the convex parts
// of seeded random star-shaped footprints (each cut into a fan from its
// centre here, not by the prism's own ear clipping), dense sampling along
// segments, and an even-odd point test of the triangulation.
#include "core/environment/prism.h"

#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "core/environment/obstacle.h"
#include "fcl/geometry/shape/box.h"
#include "fcl/geometry/shape/convex.h"
#include "fcl/geometry/shape/sphere.h"
#include "fcl/narrowphase/distance.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace oaipp {
namespace {

using ::testing::HasSubstr;

// An L: [0, 20] x [0, 8] and [0, 8] x [8, 20], 12 m tall.
Prism LHall() {
  return *Prism::Create({{0, 0}, {20, 0}, {20, 8}, {8, 8}, {8, 20}, {0, 20}}, 0.0, 12.0);
}

TEST(PrismTest, SignedDistanceOfAnLHasItsClosedForms) {
  const Prism hall = LHall();
  EXPECT_DOUBLE_EQ(hall.SignedDistance({25, 4, 6}), 5.0);                     // east wall
  EXPECT_DOUBLE_EQ(hall.SignedDistance({14, 14, 6}), 6.0);                    // in the notch
  EXPECT_DOUBLE_EQ(hall.SignedDistance({4, 4, 15}), 3.0);                     // over the roof
  EXPECT_DOUBLE_EQ(hall.SignedDistance({25, 4, 16}), std::hypot(5.0, 4.0));   // roof edge
  EXPECT_DOUBLE_EQ(hall.SignedDistance({11, 11, -2}), std::hypot(3.0, 2.0));  // notch, below
  EXPECT_DOUBLE_EQ(hall.SignedDistance({4, 4, 6}), -4.0);    // nearest wall 4 m off
  EXPECT_DOUBLE_EQ(hall.SignedDistance({2, 10, 11}), -1.0);  // the roof 1 m up
  const Aabb box = hall.BoundingBox();
  EXPECT_EQ(box.min_W, Vec3(0, 0, 0));
  EXPECT_EQ(box.max_W, Vec3(20, 20, 12));
  // The same through the obstacle interface, and its outline.
  const Shape shape = hall;
  EXPECT_DOUBLE_EQ(SignedDistance(shape, {14, 14, 6}), 6.0);
  EXPECT_EQ(GroundFootprint(shape).size(), 6u);
}

TEST(PrismTest, EitherOrientationGivesTheSamePrismCounterClockwise) {
  const Prism ccw = LHall();
  const Prism cw = *Prism::Create({{0, 20}, {8, 20}, {8, 8}, {20, 8}, {20, 0}, {0, 0}, {0, 20}},
                                  0.0, 12.0);  // closing vertex repeated
  ASSERT_EQ(cw.footprint().size(), 6u);
  double twice_area = 0.0;
  for (std::size_t i = 0; i < 6; ++i) {
    const Vec2& a = cw.footprint()[i];
    const Vec2& b = cw.footprint()[(i + 1) % 6];
    twice_area += a.x() * b.y() - a.y() * b.x();
  }
  EXPECT_DOUBLE_EQ(twice_area, 2.0 * (20 * 8 + 8 * 12));  // positive: counter-clockwise
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-5, 25);
  for (int k = 0; k < 200; ++k) {
    const Vec3 p(u(rng), u(rng), u(rng));
    EXPECT_DOUBLE_EQ(cw.SignedDistance(p), ccw.SignedDistance(p));
  }
}

// A star around (cx, cy): n vertices at seeded radii in [r0, r1], at
// increasing angles, so every fan triangle from the centre lies inside.
std::vector<Vec2> Star(std::mt19937& rng, int n, double cx, double cy, double r0, double r1) {
  std::uniform_real_distribution<double> radius(r0, r1), jitter(-0.3, 0.3);
  std::vector<Vec2> ring;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * kPi * (i + 0.5 + jitter(rng)) / n;
    const double r = radius(rng);
    ring.emplace_back(cx + r * std::cos(a), cy + r * std::sin(a));
  }
  return ring;
}

// FCL's distance from a point to the union of the fan's triangular prisms.
double FclFanDistance(const std::vector<Vec2>& star, const Vec2& centre, double base, double top,
                      const Vec3& p) {
  constexpr double kTiny = 1e-7;
  auto sphere = std::make_shared<fcl::Sphered>(kTiny);
  fcl::CollisionObjectd point(sphere, fcl::Transform3d(Eigen::Translation3d(p)));
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < star.size(); ++i) {
    const Vec2& a = star[i];
    const Vec2& b = star[(i + 1) % star.size()];
    auto vertices =
        std::make_shared<std::vector<Vec3>>(std::vector<Vec3>{{centre.x(), centre.y(), base},
                                                              {a.x(), a.y(), base},
                                                              {b.x(), b.y(), base},
                                                              {centre.x(), centre.y(), top},
                                                              {a.x(), a.y(), top},
                                                              {b.x(), b.y(), top}});
    // Faces, outward and counter-clockwise seen from outside.
    auto faces = std::make_shared<std::vector<int>>(
        std::vector<int>{3, 0, 2, 1, 3, 3, 4, 5, 4, 0, 1, 4, 3, 4, 1, 2, 5, 4, 4, 2, 0, 3, 5});
    auto convex = std::make_shared<fcl::Convexd>(vertices, 5, faces);
    fcl::CollisionObjectd object(convex, fcl::Transform3d::Identity());
    fcl::DistanceRequestd request;
    fcl::DistanceResultd result;
    fcl::distance(&point, &object, request, result);
    best = std::min(best, result.min_distance + kTiny);
  }
  return best;
}

TEST(PrismTest, OutsideDistanceMatchesFclOnRandomStarFootprints) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> coord(-25, 25), up(-5, 30);
  int compared = 0;
  for (int trial = 0; trial < 12; ++trial) {
    const std::vector<Vec2> star = Star(rng, 5 + trial, 0.0, 0.0, 3.0, 12.0);
    const absl::StatusOr<Prism> prism = Prism::Create(star, 2.0, 18.0);
    ASSERT_TRUE(prism.ok()) << prism.status();
    for (int k = 0; k < 60; ++k) {
      const Vec3 p(coord(rng), coord(rng), up(rng));
      const double ours = prism->SignedDistance(p);
      if (ours < 1e-3) continue;  // FCL reports penetration differently
      EXPECT_NEAR(ours, FclFanDistance(star, {0, 0}, 2.0, 18.0, p), 1e-5)
          << "trial " << trial << " at " << p.transpose();
      ++compared;
    }
  }
  EXPECT_GT(compared, 500);
}

TEST(PrismTest, TheTrianglesCoverTheFootprintExactly) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> coord(-14, 14);
  for (int trial = 0; trial < 20; ++trial) {
    const std::vector<Vec2> star = Star(rng, 4 + 3 * trial, 1.0, -2.0, 2.0, 12.0);
    const absl::StatusOr<Prism> prism = Prism::Create(star, 0.0, 1.0);
    ASSERT_TRUE(prism.ok()) << prism.status();
    EXPECT_EQ(prism->triangles().size(), star.size() - 2) << trial;
    for (int k = 0; k < 300; ++k) {
      const Vec2 p(coord(rng), coord(rng));
      // Even-odd, written here.
      bool inside = false;
      for (std::size_t i = 0, j = star.size() - 1; i < star.size(); j = i++) {
        if ((star[i].y() > p.y()) != (star[j].y() > p.y()) &&
            p.x() <
                (star[j].x() - star[i].x()) * (p.y() - star[i].y()) / (star[j].y() - star[i].y()) +
                    star[i].x()) {
          inside = !inside;
        }
      }
      int covering = 0;
      for (const auto& t : prism->triangles()) {
        bool in = true;
        for (int e = 0; e < 3; ++e) {
          const Vec2 a = t[e], b = t[(e + 1) % 3];
          in = in && (b - a).x() * (p - a).y() - (b - a).y() * (p - a).x() > 0.0;
        }
        covering += in;
      }
      EXPECT_EQ(covering, inside ? 1 : 0) << "trial " << trial << " at " << p.transpose();
    }
  }
}

TEST(PrismTest, SegmentQueriesAgreeWithDenseSampling) {
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> coord(-20, 20), up(-2, 24);
  int hits = 0, misses = 0;
  for (int trial = 0; trial < 6; ++trial) {
    const Shape shape = *Prism::Create(Star(rng, 9, 0.0, 0.0, 3.0, 10.0), 4.0, 16.0);
    for (int k = 0; k < 60; ++k) {
      const Vec3 a(coord(rng), coord(rng), up(rng)), b(coord(rng), coord(rng), up(rng));
      constexpr int kSamples = 8000;
      double sampled = std::numeric_limits<double>::infinity();
      int inside = 0;
      for (int s = 0; s <= kSamples; ++s) {
        const double d = SignedDistance(shape, a + (b - a) * s / kSamples);
        sampled = std::min(sampled, d);
        inside += d < 0.0;
      }
      const double step = (b - a).norm() / kSamples;
      const double exact = SegmentSignedDistance(shape, a, b);
      if (sampled > 0.0) {
        // Outside: exact, so the samples can only be higher, by half a step.
        EXPECT_LE(exact, sampled + 1e-9);
        EXPECT_GE(exact, sampled - 0.5 * step - 1e-9);
      } else {
        EXPECT_LE(exact, 0.5 * step);
      }
      // Well inside or well clear: the hit test agrees.
      if (inside > 4) {
        EXPECT_TRUE(SegmentHits(shape, a, b)) << trial << "/" << k;
        ++hits;
      } else if (sampled > step) {
        EXPECT_FALSE(SegmentHits(shape, a, b)) << trial << "/" << k;
        ++misses;
      }
    }
  }
  EXPECT_GT(hits, 30);
  EXPECT_GT(misses, 30);
}

// Seeded random L-shaped buildings (a reflex corner each) against the two
// boxes whose union they are: outside, the distance to a union is the
// nearer part's, for points and along segments.
TEST(PrismTest, AnLIsTheUnionOfItsTwoBoxes) {
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> corner(-10, 0), arm(3, 9), width(1, 3), coord(-15, 15),
      up(-3, 25);
  int compared = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const double x0 = corner(rng), y0 = corner(rng), w = arm(rng), h = arm(rng), t = width(rng);
    const Shape l = *Prism::Create({{x0, y0},
                                    {x0 + w, y0},
                                    {x0 + w, y0 + t},
                                    {x0 + t, y0 + t},
                                    {x0 + t, y0 + h},
                                    {x0, y0 + h}},
                                   0.0, 20.0);
    const Shape a = Box{{x0 + 0.5 * w, y0 + 0.5 * t, 10.0}, {w, t, 20.0}, 0.0};
    const Shape b = Box{{x0 + 0.5 * t, y0 + 0.5 * h, 10.0}, {t, h, 20.0}, 0.0};
    for (int k = 0; k < 100; ++k) {
      const Vec3 p(coord(rng), coord(rng), up(rng)), q(coord(rng), coord(rng), up(rng));
      const double boxes = std::min(SignedDistance(a, p), SignedDistance(b, p));
      if (boxes > 0.0) {
        EXPECT_NEAR(SignedDistance(l, p), boxes, 1e-12) << trial;
      }
      const double along = std::min(SegmentSignedDistance(a, p, q), SegmentSignedDistance(b, p, q));
      if (along > 0.0) {
        EXPECT_NEAR(SegmentSignedDistance(l, p, q), along, 1e-9) << trial << "/" << k;
        ++compared;
      } else {
        EXPECT_LE(SegmentSignedDistance(l, p, q), 1e-9) << trial << "/" << k;
      }
    }
  }
  EXPECT_GT(compared, 1000);
}

TEST(PrismTest, BadFootprintsAreRefusedNamingTheField) {
  struct Bad {
    std::vector<Vec2> footprint;
    double base, top;
    std::string message;
  };
  std::vector<Vec2> many;
  for (int i = 0; i < kMaxPrismVertices + 1; ++i) {
    const double a = 2.0 * kPi * i / (kMaxPrismVertices + 1);
    many.emplace_back(std::cos(a), std::sin(a));
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Bad> bad = {
      {{{0, 0}, {1, 1}}, 0, 1, "b.prism.footprint: needs at least 3 distinct vertices, got 2"},
      {{{0, 0}, {4, 4}, {4, 0}, {0, 4}}, 0, 1, "b.prism.footprint: edges 0 and 2 cross or touch"},
      {{{0, 0}, {4, 0}, {4, 4}, {2, 0}}, 0, 1, "b.prism.footprint: edges"},
      {{{0, 0}, {2, 0}, {4, 0}}, 0, 1, "b.prism.footprint: edges"},
      {{{0, 0}, {nan, 0}, {4, 4}}, 0, 1, "b.prism.footprint[1]: must be finite"},
      {many, 0, 1, "b.prism.footprint: 257 vertices, more than 256"},
      {{{0, 0}, {4, 0}, {4, 4}}, 3, 3, "b.prism.top_m: must be finite and above base_m"},
      {{{0, 0}, {4, 0}, {4, 4}}, nan, 3, "b.prism.base_m: must be finite"},
  };
  for (const Bad& b : bad) {
    const absl::StatusOr<Prism> prism = Prism::Create(b.footprint, b.base, b.top, "b.prism");
    ASSERT_FALSE(prism.ok()) << b.message;
    EXPECT_EQ(prism.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(prism.status().message(), HasSubstr(b.message));
  }
}

}  // namespace
}  // namespace oaipp
