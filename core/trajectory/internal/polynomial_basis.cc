#include "core/trajectory/internal/polynomial_basis.h"

#include "Eigen/LU"

namespace oaipp::internal {
namespace {

long double FallingFactorialL(int k, int r) {
  long double f = 1.0L;
  for (int i = 0; i < r; ++i) f *= static_cast<long double>(k - i);
  return f;
}

PolynomialBasis ComputeBasis() {
  // A: row r is the r-th s-derivative at s = 0, row 5 + r the one at s = 1.
  Matrix10L a = Matrix10L::Zero();
  for (int r = 0; r < kNumEndpointDerivatives; ++r) {
    a(r, r) = FallingFactorialL(r, r);
    for (int k = r; k < kNumCoefficients; ++k) {
      a(kNumEndpointDerivatives + r, k) = FallingFactorialL(k, r);
    }
  }
  // Q_ij = (i!/(i-4)!) (j!/(j-4)!) / (i + j - 7), the integral of the product
  // of the snap monomials.
  Matrix10L q = Matrix10L::Zero();
  for (int i = 4; i < kNumCoefficients; ++i) {
    for (int j = 4; j < kNumCoefficients; ++j) {
      q(i, j) =
          FallingFactorialL(i, 4) * FallingFactorialL(j, 4) / static_cast<long double>(i + j - 7);
    }
  }
  // A is integer with entries up to 9!/5! and a modest condition number; a
  // full-pivot LU in long double leaves errors far below double precision.
  const Matrix10L a_inv = a.fullPivLu().inverse();
  Matrix10L h = a_inv.transpose() * q * a_inv;
  h = 0.5L * (h + h.transpose());
  return {a_inv, q.cast<double>(), h.cast<double>()};
}

}  // namespace

const PolynomialBasis& Basis() {
  static const PolynomialBasis* const basis = new PolynomialBasis(ComputeBasis());
  return *basis;
}

}  // namespace oaipp::internal
