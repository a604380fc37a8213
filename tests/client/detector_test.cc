// The simulated detector's statistics against its configured probabilities
// over many seeded draws.
#include <cmath>

#include "absl/strings/str_cat.h"
#include "client/scenario.h"
#include "client/simulation.h"
#include "gtest/gtest.h"

namespace oaipp::client {
namespace {

// One person at the field centre, no obstacles, no false positives unless
// asked for.
Simulation OnePerson(double fp_rate) {
  auto s = ParseScenario(
      absl::StrCat(
          R"({"targets": [{"x_min_m": -0.375, "x_max_m": 0.375, "y_min_m": -1, "y_max_m": 1}],)",
          R"("detector": {"fp_per_image_at_10m": )", fp_rate, "}}"),
      "test");
  EXPECT_TRUE(s.ok()) << s.status();
  auto sim = Simulation::Create(*s);
  EXPECT_TRUE(sim.ok()) << sim.status();
  return std::move(sim).value();
}

// Counts boxes that contain the image centre (the person under the camera).
double DetectionRate(const Simulation& sim, double altitude_m, int draws, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  int hits = 0;
  for (int i = 0; i < draws; ++i) {
    for (const PixelBox& b : sim.Detect(Vec3(0, 0, altitude_m), rng)) {
      if (b.x_min_px <= 240 && b.x_max_px >= 240 && b.y_min_px <= 320 && b.y_max_px >= 320) {
        ++hits;
        break;
      }
    }
  }
  return static_cast<double>(hits) / draws;
}

TEST(DetectorTest, DetectionFrequencyMatchesTheConfiguredCurve) {
  const Simulation sim = OnePerson(0.0);
  constexpr int kDraws = 20000;
  for (double h : {5.0, 10.0, 20.0, 25.0}) {
    // p(h) = 0.95 exp(-((h - 10) / 7)^2 / 2), computed here independently.
    const double p = 0.95 * std::exp(-0.5 * std::pow((h - 10.0) / 7.0, 2));
    const double sigma = std::sqrt(p * (1 - p) / kDraws);
    EXPECT_NEAR(DetectionRate(sim, h, kDraws, 7), p, 4 * sigma + 1e-9) << "h = " << h;
  }
}

TEST(DetectorTest, FalsePositivesArePoissonWithTheConfiguredMean) {
  // No target in view from far away: every box is a false positive.
  const Simulation sim = OnePerson(0.5);
  std::mt19937_64 rng(11);
  constexpr int kDraws = 20000;
  for (double h : {10.0, 20.0}) {
    double sum = 0, sum2 = 0;
    for (int i = 0; i < kDraws; ++i) {
      const double n = static_cast<double>(sim.Detect(Vec3(12, 12, h), rng).size());
      sum += n;
      sum2 += n * n;
    }
    const double mean = sum / kDraws, var = sum2 / kDraws - mean * mean;
    const double expected = 0.5 * (h / 10) * (h / 10);
    EXPECT_NEAR(mean, expected, 4 * std::sqrt(expected / kDraws)) << "h = " << h;
    EXPECT_NEAR(var, expected, 0.1 * expected) << "Poisson: variance = mean";
  }
}

TEST(DetectorTest, SameSeedSameDetections) {
  const Simulation sim = OnePerson(1.0);
  std::mt19937_64 a(3), b(3);
  for (int i = 0; i < 50; ++i) {
    const auto x = sim.Detect(Vec3(0, 0, 12), a), y = sim.Detect(Vec3(0, 0, 12), b);
    ASSERT_EQ(x.size(), y.size());
    for (std::size_t k = 0; k < x.size(); ++k) EXPECT_EQ(x[k].x_min_px, y[k].x_min_px);
  }
}

}  // namespace
}  // namespace oaipp::client
