// Helpers shared by the trajectory tests: seeded random waypoint sets and a
// real-time polynomial evaluator that does not go through the class under
// test.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include "core/common/geometry.h"
#include "core/trajectory/polynomial_trajectory.h"

namespace oaipp::testing {

// The paper's E1 flight volume (docs/method.md §10): 30 x 30 m, altitude 2..26 m.
inline Vec3 RandomPoint(std::mt19937& rng) {
  std::uniform_real_distribution<double> xy(-15.0, 15.0), z(2.0, 26.0);
  return {xy(rng), xy(rng), z(rng)};
}

inline std::vector<Vec3> RandomWaypoints(std::mt19937& rng, int count) {
  std::vector<Vec3> w;
  for (int i = 0; i < count; ++i) w.push_back(RandomPoint(rng));
  return w;
}

// A vector with uniformly random direction and norm uniform in [0, max_norm].
inline Vec3 RandomVector(std::mt19937& rng, double max_norm) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vec3 d(n(rng), n(rng), n(rng));
  return std::uniform_real_distribution<double>(0.0, max_norm)(rng) * d.normalized();
}

// d^order/dtau^order of sum_k C(k, a) tau^k, by direct summation.
inline Vec3 EvalRealTime(const PolynomialTrajectory::SegmentCoefficients& c, double tau,
                         int order) {
  Vec3 v = Vec3::Zero();
  for (int k = order; k < c.rows(); ++k) {
    double f = 1.0;
    for (int i = 0; i < order; ++i) f *= k - i;
    v += f * std::pow(tau, k - order) * c.row(k).transpose();
  }
  return v;
}

// Composite Simpson's rule of |d^4 p / dt^4|^2 over every segment, through
// the public Derivative() (independent of the closed-form SnapCost()).
inline double SimpsonSnapCost(const PolynomialTrajectory& traj, int intervals_per_segment) {
  double total = 0.0;
  for (int j = 0; j < traj.NumSegments(); ++j) {
    const double t0 = traj.SegmentStartTime(j), T = traj.SegmentDurations()[j];
    const double h = T / intervals_per_segment;
    // Stay strictly inside the segment so its own polynomial is used.
    const auto f = [&](double t) {
      return traj.Derivative(std::clamp(t, t0, t0 + T * (1 - 1e-12)), 4).squaredNorm();
    };
    double sum = f(t0) + f(t0 + T);
    for (int i = 1; i < intervals_per_segment; ++i) sum += (i % 2 ? 4.0 : 2.0) * f(t0 + i * h);
    total += sum * h / 3.0;
  }
  return total;
}

}  // namespace oaipp::testing
