// Dense references for the sparse map's tests: what its prior is as a
// dense covariance, computed without CHOLMOD.
#pragma once

#include "Eigen/Core"
#include "Eigen/SparseCholesky"
#include "core/mapping/gmrf_prior.h"
#include "gtest/gtest.h"

namespace oaipp::testing {

// The prior's covariance over the field: the field's columns of Q^-1 (its
// whole precision, margin included), solved with Eigen's own sparse
// Cholesky (not CHOLMOD, which the map uses), and the field's rows of them.
inline Eigen::MatrixXd DenseFieldCovariance(const GmrfPrior& prior) {
  const Eigen::SparseMatrix<double> q = prior.precision.selfadjointView<Eigen::Lower>();
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(q);
  EXPECT_EQ(ldlt.info(), Eigen::Success);
  const int n = static_cast<int>(prior.field_state.size());
  Eigen::MatrixXd columns = Eigen::MatrixXd::Zero(q.rows(), n);
  for (int j = 0; j < n; ++j) columns(prior.field_state[j], j) = 1.0;
  columns = ldlt.solve(columns);
  Eigen::MatrixXd field(n, n);
  for (int i = 0; i < n; ++i) field.row(i) = columns.row(prior.field_state[i]);
  return 0.5 * (field + field.transpose());
}

}  // namespace oaipp::testing
