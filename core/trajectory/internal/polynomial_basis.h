// Constant matrices of the degree-9 polynomial basis in normalised time
// s = t / T in [0, 1], shared by the min-snap solver and the trajectory.
//
// Working in normalised time keeps every matrix here independent of the
// segment duration; the duration enters only through diagonal scalings
// T^r (docs/method.md §5; Richter, Bry & Roy 2016, Sec. 3), which keeps segments
// from 0.1 s to 60 s equally well conditioned.
//
//   const internal::PolynomialBasis& basis = internal::Basis();
//   SegmentCoefficients c = basis.coeffs_from_endpoints * endpoint_derivs;
//   double cost = c.col(0).dot(basis.snap_cost_coeffs * c.col(0)) / std::pow(T, 7);
#pragma once

#include "Eigen/Core"

namespace oaipp::internal {

inline constexpr int kPolynomialDegree = 9;
inline constexpr int kNumCoefficients = kPolynomialDegree + 1;
// Derivatives 0..4 (position .. snap) are fixed or continuous at waypoints.
inline constexpr int kNumEndpointDerivatives = 5;

using Matrix10 = Eigen::Matrix<double, kNumCoefficients, kNumCoefficients>;
using Matrix10L = Eigen::Matrix<long double, kNumCoefficients, kNumCoefficients>;

struct PolynomialBasis {
  // A^-1: maps the endpoint derivatives in s,
  //   [p(0), p'(0), .., p''''(0), p(1), p'(1), .., p''''(1)],
  // to the coefficients c_0..c_9 of p(s) = sum_k c_k s^k.
  //
  // Kept in long double: next to a much longer segment, a short segment is
  // nearly cubic in s, and its small high-order coefficients are what is
  // left after cancellation among the endpoint values; in double that loses
  // up to ~1e-6 of its end snap (seen with 0.1 s next to 40 s segments).
  Matrix10L coeffs_from_endpoints;
  // Q: integral over s in [0, 1] of (d^4 p / ds^4)^2 = c^T Q c.
  Matrix10 snap_cost_coeffs;
  // H = A^-T Q A^-1: the same cost as a quadratic form in the endpoint
  // derivatives in s (Richter et al. 2016: the cost c^T Q c with the
  // coefficients c = A^-1 d written through the endpoint derivatives d).
  Matrix10 snap_cost_endpoints;
};

// The basis, computed once (in long double, then rounded) on first use.
// Thread-safe.
[[nodiscard]] const PolynomialBasis& Basis();

// k! / (k - r)!: the factor d^r/ds^r brings to the coefficient of s^k.
[[nodiscard]] constexpr double FallingFactorial(int k, int r) {
  double f = 1.0;
  for (int i = 0; i < r; ++i) f *= static_cast<double>(k - i);
  return f;
}

}  // namespace oaipp::internal
