#include "core/mapping/gp_map.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <numeric>
#include <utility>

#include "Eigen/Cholesky"
#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"
#include "core/mapping/dense_backend.h"

namespace oaipp {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

// Block edge for the cache-blocked passes over n x n matrices: two 64 x 64
// blocks of doubles (64 KB) stay in L2 while one is transposed into the other.
constexpr Index kBlock = 64;

// Copies the strict lower triangle onto the strict upper one, so that P is
// exactly symmetric after a lower-triangle-only update. Block by block: a
// plain element-wise transpose would stride through 20 MB column-major data.
void MirrorLowerToUpper(MatrixXd& m) {
  const Index n = m.rows();
  for (Index j0 = 0; j0 < n; j0 += kBlock) {
    const Index jb = std::min(kBlock, n - j0);
    for (Index i0 = 0; i0 < j0; i0 += kBlock) {
      const Index ib = std::min(kBlock, n - i0);
      // Upper block (i0, j0) from lower block (j0, i0); the two do not overlap.
      m.block(i0, j0, ib, jb) = m.block(j0, i0, jb, ib).transpose();
    }
    for (Index j = j0; j < j0 + jb; ++j) {
      for (Index i = j0; i < j; ++i) m(i, j) = m(j, i);
    }
  }
}

// The factors of one Kalman update over merged, validated observations:
// L L^T = S = P_JJ + R and Bt = P_:J L^-T (n x m), so that
//   P_:J S^-1 P_J: = Bt Bt^T   and   W (z - mu_J) = Bt L^-1 (z - mu_J).
// Returns false when S is not positive definite.
struct UpdateFactors {
  MatrixXd lower;  // L in the lower triangle (above it: unspecified)
  MatrixXd bt;
};

bool Factor(const DenseBackend& backend, const MatrixXd& p, std::span<const CellObservation> obs,
            UpdateFactors& f) {
  const Index n = p.rows();
  const Index m = static_cast<Index>(obs.size());
  // P_:J is m contiguous columns of the column-major P.
  f.bt.resize(n, m);
  for (Index k = 0; k < m; ++k) f.bt.col(k) = p.col(obs[k].cell);
  f.lower.resize(m, m);
  for (Index b = 0; b < m; ++b) {
    for (Index a = 0; a < m; ++a) f.lower(a, b) = f.bt(obs[a].cell, b);
    f.lower(b, b) += obs[b].variance;
  }
  // On the dense backend: for a shot from 26 m (m = 1120) the factor is
  // m^3 / 3 flops, a third of the update's time on Eigen's generic kernels.
  if (!backend.CholeskyLowerInPlace(f.lower)) return false;
  // Bt = P_:J L^-T: a right-side triangular solve with U = L^T.
  backend.SolveRightLowerTransposed(f.lower, f.bt);
  return true;
}

absl::Status NotPositiveDefinite() {
  return absl::InternalError(
      "Kalman update: innovation covariance S = P_JJ + R is not positive definite (the map's "
      "covariance has lost positive semi-definiteness)");
}

absl::Status CheckSquare(const MatrixXd& covariance) {
  if (covariance.rows() != covariance.cols()) {
    return absl::InvalidArgumentError(absl::StrCat("covariance: must be square, got ",
                                                   covariance.rows(), " x ", covariance.cols()));
  }
  return absl::OkStatus();
}

// The Kalman update of a shot that sees most of the field (m >= n / 2
// cells, e.g. from 26 m), block by block over the observed cells J and the
// rest C (c = n - m cells), with S = P_JJ + R = L L^T:
//   P_CC -= X X^T          with X = P_CJ L^-T        c^2 m / 2 + c m^2 / 2
//   P_CJ := P_CJ S^-1 R = X L^-1 R                     c m^2 / 2
//   P_JJ := P_JJ S^-1 R = R - R S^-1 R                 m^3 / 3 (potri)
// (P_JJ S^-1 = (S - R) S^-1 = I - R S^-1). The whole-matrix form,
// P -= Bt Bt^T with Bt = P_:J L^-T, costs n^2 m / 2 + n m^2 / 2: for m = 1120
// of 1600 cells 2.4 G multiply-adds against 1.5 G here. R - R S^-1 R also
// avoids the cancellation of P_JJ - P_JJ S^-1 P_JJ when R is small against
// P_JJ. Writes the whole of `out` (both triangles), column by column, after
// every read of p: `out` may be p, or a new n x n matrix.
absl::Status UpdateMostCells(const DenseBackend& backend, std::span<const CellObservation> obs,
                             VectorXd& mean, const MatrixXd& p, MatrixXd& out) {
  const Index n = p.rows();
  const Index m = static_cast<Index>(obs.size());
  std::vector<bool> observed(static_cast<std::size_t>(n), false);
  for (const CellObservation& o : obs) observed[static_cast<std::size_t>(o.cell)] = true;
  std::vector<int> rest;  // C
  rest.reserve(static_cast<std::size_t>(n - m));
  for (Index i = 0; i < n; ++i) {
    if (!observed[static_cast<std::size_t>(i)]) rest.push_back(static_cast<int>(i));
  }
  const Index c = static_cast<Index>(rest.size());
  MatrixXd lower(m, m);
  MatrixXd x(c, m);
  for (Index k = 0; k < m; ++k) {
    const auto column = p.col(obs[k].cell);
    for (Index a = 0; a < m; ++a) lower(a, k) = column[obs[a].cell];
    lower(k, k) += obs[k].variance;
    for (Index a = 0; a < c; ++a) x(a, k) = column[rest[a]];
  }
  if (!backend.CholeskyLowerInPlace(lower)) return NotPositiveDefinite();
  // Nothing fails from here on: the map changes only now.
  backend.SolveRightLowerTransposed(lower, x);  // X = P_CJ L^-T
  // mu_C += P_CJ S^-1 (z - mu_J) = X L^-1 (z - mu_J);
  // mu_J += P_JJ S^-1 (z - mu_J) = (z - mu_J) - R S^-1 (z - mu_J).
  VectorXd innovation(m);
  for (Index k = 0; k < m; ++k) innovation[k] = obs[k].value - mean[obs[k].cell];
  VectorXd whitened = innovation;
  lower.triangularView<Eigen::Lower>().solveInPlace(whitened);
  VectorXd solved = whitened;
  lower.triangularView<Eigen::Lower>().transpose().solveInPlace(solved);
  const VectorXd mean_rest = x * whitened;
  for (Index a = 0; a < c; ++a) mean[rest[a]] += mean_rest[a];
  for (Index k = 0; k < m; ++k) {
    mean[obs[k].cell] += innovation[k] - obs[k].variance * solved[k];
  }
  // P_CC - X X^T (lower triangle, then mirrored: c x c is small).
  MatrixXd rest_block(c, c);
  for (Index b = 0; b < c; ++b) {
    const auto column = p.col(rest[b]);
    for (Index a = b; a < c; ++a) rest_block(a, b) = column[rest[a]];
  }
  backend.SymmetricRankUpdate(-1.0, x, rest_block);
  rest_block.triangularView<Eigen::StrictlyUpper>() = rest_block.transpose();
  // X L^-1 R, also transposed (m x c), so that both the columns of J and
  // those of C read it in order.
  backend.SolveRightLower(lower, x);
  for (Index k = 0; k < m; ++k) x.col(k) *= obs[k].variance;
  const MatrixXd cross = x.transpose();
  // R - R S^-1 R.
  backend.InverseFromCholeskyInPlace(lower);
  MatrixXd seen(m, m);
  for (Index b = 0; b < m; ++b) {
    for (Index a = b; a < m; ++a) {
      seen(a, b) = -obs[a].variance * lower(a, b) * obs[b].variance;
      seen(b, a) = seen(a, b);
    }
    seen(b, b) += obs[b].variance;
  }
  // Each column of p from its two sources, by the rows of J and of C.
  auto scatter = [&](Index j, const auto& from_j, const auto& from_c) {
    double* column = out.col(j).data();
    for (Index a = 0; a < m; ++a) column[obs[a].cell] = from_j[a];
    for (Index a = 0; a < c; ++a) column[rest[a]] = from_c[a];
  };
  for (Index k = 0; k < m; ++k) scatter(obs[k].cell, seen.col(k), x.col(k));
  for (Index b = 0; b < c; ++b) scatter(rest[b], cross.col(b), rest_block.col(b));
  return absl::OkStatus();
}

// The lower triangle of (L L^T)^-1 = L^-T L^-1 from a lower Cholesky factor,
// in about 2 n^3 / 3 flops by skipping the known zeros of L^-1 (LAPACK's
// potri does the same; Eigen has no counterpart). `l` is overwritten.
MatrixXd InverseFromCholesky(MatrixXd& l) {
  const Index n = l.rows();
  // L^-1 column block by column block: its block [j0, j1) is zero above row
  // j0 and solves L[j0:, j0:] X = I[j0:, j0:j1], n^3 / 3 flops in all.
  MatrixXd l_inv = MatrixXd::Zero(n, n);
  constexpr Index kPanel = 128;
  for (Index j0 = 0; j0 < n; j0 += kPanel) {
    const Index jb = std::min(kPanel, n - j0);
    auto x = l_inv.block(j0, j0, n - j0, jb);
    x.topRows(jb).setIdentity();
    l.block(j0, j0, n - j0, n - j0).triangularView<Eigen::Lower>().solveInPlace(x);
  }
  // L^-T L^-1 = sum over row panels R of L^-1 of R^T R, where the panel of
  // rows [k0, k1) is zero right of column k1: a rank update of the leading
  // k1 x k1 block only, n^3 / 3 flops in all.
  MatrixXd inv = MatrixXd::Zero(n, n);
  for (Index k0 = 0; k0 < n; k0 += kPanel) {
    const Index k1 = std::min(k0 + kPanel, n);
    inv.topLeftCorner(k1, k1).selfadjointView<Eigen::Lower>().rankUpdate(
        l_inv.block(k0, 0, k1 - k0, k1).transpose());
  }
  return inv;
}

}  // namespace

absl::StatusOr<std::vector<CellObservation>> MergeObservations(
    std::span<const CellObservation> observations, int num_cells, bool check_values) {
  for (std::size_t i = 0; i < observations.size(); ++i) {
    const CellObservation& o = observations[i];
    if (o.cell < 0 || o.cell >= num_cells) {
      return absl::InvalidArgumentError(
          absl::StrCat("observations[", i, "].cell: ", o.cell, " is outside [0, ", num_cells, ")"));
    }
    if (!std::isfinite(o.variance) || !(o.variance > 0.0) || !std::isfinite(1.0 / o.variance)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "observations[", i, "].variance: must be positive and finite, got ", o.variance));
    }
    if (check_values && !std::isfinite(o.value)) {
      return absl::InvalidArgumentError(
          absl::StrCat("observations[", i, "].value: must be finite, got ", o.value));
    }
  }
  std::vector<std::size_t> order(observations.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return observations[a].cell < observations[b].cell;
  });
  std::vector<CellObservation> merged;
  merged.reserve(observations.size());
  for (std::size_t k = 0; k < order.size();) {
    const int cell = observations[order[k]].cell;
    if (k + 1 == order.size() || observations[order[k + 1]].cell != cell) {
      // The common case, copied as is so that no round-off is introduced.
      CellObservation o = observations[order[k]];
      if (!check_values) o.value = 0.0;
      merged.push_back(o);
      ++k;
      continue;
    }
    // Independent Gaussian readings of one cell: the information form adds.
    double precision = 0.0;
    double weighted = 0.0;
    const std::size_t first = k;
    for (; k < order.size() && observations[order[k]].cell == cell; ++k) {
      const CellObservation& o = observations[order[k]];
      precision += 1.0 / o.variance;
      if (check_values) weighted += o.value / o.variance;
    }
    const double value = weighted / precision;
    if (!std::isfinite(precision) || !std::isfinite(value)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "observations[", order[first], "]: merging the readings of cell ", cell, " overflows"));
    }
    merged.push_back({.cell = cell, .value = value, .variance = 1.0 / precision});
  }
  return merged;
}

namespace {

absl::Status CheckDenseSize(const FieldGrid& grid) {
  if (grid.num_cells() > kMaxDenseCells) {
    return absl::ResourceExhaustedError(absl::StrCat("the dense map holds at most ", kMaxDenseCells,
                                                     " cells (8 n^2 bytes), got ",
                                                     grid.num_cells()));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<MatrixXd> PriorCovariance(const FieldGrid& grid, const GpParams& params) {
  OAIPP_RETURN_IF_ERROR(params.Validate());
  OAIPP_RETURN_IF_ERROR(CheckDenseSize(grid));
  const int nx = grid.nx();
  const int ny = grid.ny();
  const Index n = grid.num_cells();
  // On a regular grid k depends only on the row and column offsets: a table
  // of ny x nx values replaces n^2 exponentials.
  MatrixXd k_table(nx, ny);
  for (int dr = 0; dr < ny; ++dr) {
    for (int dc = 0; dc < nx; ++dc) {
      k_table(dc, dr) = Matern32(
          grid.resolution_m() * std::hypot(static_cast<double>(dc), static_cast<double>(dr)),
          params.length_scale_m, params.signal_var);
    }
  }
  // P0 = K - K A^-1 K with A = K + sn2 I. K and A commute and K = A - sn2 I,
  // so K A^-1 K = K - sn2 I + sn2^2 A^-1 and P0 = sn2 I - sn2^2 A^-1: one
  // Cholesky factorisation and a triangular inverse, no n x n products of
  // general matrices. A's eigenvalues are >= sn2, so A is well conditioned
  // and the absolute error of P0 stays at round-off of sn2.
  MatrixXd a(n, n);
  for (Index j = 0; j < n; ++j) {
    const int rj = grid.Row(static_cast<int>(j));
    const int cj = grid.Col(static_cast<int>(j));
    for (Index i = j; i < n; ++i) {  // lower triangle: all the factorisation reads
      a(i, j) = k_table(std::abs(grid.Col(static_cast<int>(i)) - cj),
                        std::abs(grid.Row(static_cast<int>(i)) - rj));
    }
    a(j, j) += params.noise_var;
  }
  Eigen::LLT<Eigen::Ref<MatrixXd>> llt(a);  // factorises in place: L in a's lower triangle
  if (llt.info() != Eigen::Success) {
    return absl::InternalError("PriorCovariance: K + sn2 I is not positive definite");
  }
  a.triangularView<Eigen::StrictlyUpper>().setZero();
  MatrixXd p0 = InverseFromCholesky(a);
  const double sn2 = params.noise_var;
  p0 *= -sn2 * sn2;
  p0.diagonal().array() += sn2;
  MirrorLowerToUpper(p0);
  return p0;
}

absl::Status UpdateCovariance(std::span<const CellObservation> observations, MatrixXd& covariance,
                              const DenseBackend& backend) {
  OAIPP_RETURN_IF_ERROR(CheckSquare(covariance));
  OAIPP_ASSIGN_OR_RETURN(
      std::vector<CellObservation> merged,
      MergeObservations(observations, static_cast<int>(covariance.rows()), false));
  if (merged.empty()) return absl::OkStatus();
  UpdateFactors f;
  if (!Factor(backend, covariance, merged, f)) return NotPositiveDefinite();
  // P -= Bt Bt^T as a symmetric rank-m update of the lower triangle (half the
  // flops of a general product), then mirrored so P stays exactly symmetric.
  backend.SymmetricRankUpdate(-1.0, f.bt, covariance);
  MirrorLowerToUpper(covariance);
  return absl::OkStatus();
}

absl::StatusOr<double> TraceAfterUpdate(const MatrixXd& covariance,
                                        std::span<const CellObservation> observations,
                                        const DenseBackend& backend) {
  OAIPP_RETURN_IF_ERROR(CheckSquare(covariance));
  OAIPP_ASSIGN_OR_RETURN(
      std::vector<CellObservation> merged,
      MergeObservations(observations, static_cast<int>(covariance.rows()), false));
  if (merged.empty()) return covariance.trace();
  UpdateFactors f;
  if (!Factor(backend, covariance, merged, f)) return NotPositiveDefinite();
  return covariance.trace() - f.bt.squaredNorm();
}

absl::StatusOr<VectorXd> VariancesAfterUpdate(const MatrixXd& covariance,
                                              std::span<const CellObservation> observations,
                                              const DenseBackend& backend) {
  OAIPP_RETURN_IF_ERROR(CheckSquare(covariance));
  OAIPP_ASSIGN_OR_RETURN(
      std::vector<CellObservation> merged,
      MergeObservations(observations, static_cast<int>(covariance.rows()), false));
  if (merged.empty()) return VectorXd(covariance.diagonal());
  UpdateFactors f;
  if (!Factor(backend, covariance, merged, f)) return NotPositiveDefinite();
  return VectorXd(covariance.diagonal() - f.bt.rowwise().squaredNorm());
}

absl::StatusOr<GpMap> GpMap::Create(const FieldGrid& grid, const GpParams& params) {
  OAIPP_ASSIGN_OR_RETURN(MatrixXd p0, PriorCovariance(grid, params));
  return GpMap(grid, VectorXd::Constant(grid.num_cells(), params.prior_mean), std::move(p0));
}

absl::StatusOr<GpMap> GpMap::FromPrior(const FieldGrid& grid, VectorXd mean, MatrixXd covariance) {
  OAIPP_RETURN_IF_ERROR(CheckDenseSize(grid));
  const Index n = grid.num_cells();
  if (mean.size() != n) {
    return absl::InvalidArgumentError(
        absl::StrCat("mean: size ", mean.size(), " does not match the grid's ", n, " cells"));
  }
  if (covariance.rows() != n || covariance.cols() != n) {
    return absl::InvalidArgumentError(absl::StrCat("covariance: ", covariance.rows(), " x ",
                                                   covariance.cols(), " does not match the grid's ",
                                                   n, " cells"));
  }
  if (!AllFinite(mean)) return absl::InvalidArgumentError("mean: must be finite");
  if (!AllFinite(covariance)) return absl::InvalidArgumentError("covariance: must be finite");
  const double scale = covariance.cwiseAbs().maxCoeff();
  if ((covariance - covariance.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) {
    return absl::InvalidArgumentError("covariance: must be symmetric");
  }
  MirrorLowerToUpper(covariance);
  return GpMap(grid, std::move(mean), std::move(covariance));
}

absl::Status GpMap::Update(std::span<const CellObservation> observations) {
  return Fuse(observations, /*defer_downdate=*/false);
}

absl::Status GpMap::UpdateDeferred(std::span<const CellObservation> observations) {
  return Fuse(observations, /*defer_downdate=*/true);
}

void GpMap::Settle() {
  if (settled()) return;
  MatrixXd& p = OwnLowerTriangle();
  backend_.SymmetricRankUpdate(-1.0, pending_, p);
  MirrorLowerToUpper(p);
  pending_.resize(0, 0);
}

void GpMap::Unshare() {
  if (covariance_.use_count() > 1) covariance_ = std::make_shared<MatrixXd>(*covariance_);
}

MatrixXd& GpMap::OwnLowerTriangle() {
  // use_count() == 1: no other map holds the matrix, and none can come to
  // hold it but through this one. The others let go of it by a release
  // decrement; the acquire fence orders their reads before the writes that
  // follow (ThreadSanitizer does not model fences: GCC refuses them there).
  if (covariance_.use_count() == 1) {
#if !defined(__SANITIZE_THREAD__)
    std::atomic_thread_fence(std::memory_order_acquire);
#endif
    return *covariance_;
  }
  const MatrixXd& shared = *covariance_;
  const Index n = shared.rows();
  auto own = std::make_shared<MatrixXd>(n, n);
  // Column by column, the lower triangle: half the bytes of a whole copy
  // (std::copy_n is the C library's memmove, wider than Eigen's generic
  // x86-64 vectors here).
  for (Index j = 0; j < n; ++j) {
    std::copy_n(shared.col(j).data() + j, n - j, own->col(j).data() + j);
  }
  covariance_ = std::move(own);
  return *covariance_;
}

absl::Status GpMap::Fuse(std::span<const CellObservation> observations, bool defer_downdate) {
  OAIPP_ASSIGN_OR_RETURN(std::vector<CellObservation> merged,
                         MergeObservations(observations, num_cells()));
  if (merged.empty()) return absl::OkStatus();
  Settle();
  if (backend_.is_open_blas() && 2 * merged.size() >= static_cast<std::size_t>(num_cells())) {
    if (covariance_.use_count() == 1) {
      MatrixXd& p = OwnLowerTriangle();
      return UpdateMostCells(backend_, merged, mean_, p, p);
    }
    // Shared: the update writes every entry of a new matrix, with no copy.
    auto own = std::make_shared<MatrixXd>(num_cells(), num_cells());
    OAIPP_RETURN_IF_ERROR(UpdateMostCells(backend_, merged, mean_, *covariance_, *own));
    covariance_ = std::move(own);
    return absl::OkStatus();
  }
  UpdateFactors f;
  if (!Factor(backend_, *covariance_, merged, f)) return NotPositiveDefinite();
  // Nothing fails from here on: the map changes only now.
  // mu += W (z_J - mu_J) = Bt L^-1 (z_J - mu_J).
  VectorXd innovation(merged.size());
  for (std::size_t k = 0; k < merged.size(); ++k) {
    innovation[static_cast<Index>(k)] = merged[k].value - mean_[merged[k].cell];
  }
  f.lower.triangularView<Eigen::Lower>().solveInPlace(innovation);
  mean_.noalias() += f.bt * innovation;
  if (defer_downdate) {
    trace_after_pending_ = covariance_->trace() - f.bt.squaredNorm();
    pending_ = std::move(f.bt);
    return absl::OkStatus();
  }
  MatrixXd& p = OwnLowerTriangle();
  backend_.SymmetricRankUpdate(-1.0, f.bt, p);
  MirrorLowerToUpper(p);
  return absl::OkStatus();
}

absl::Status GpMap::FuseNearCertainZeros(std::span<const int> cells) {
  std::vector<int> unique(cells.begin(), cells.end());
  std::sort(unique.begin(), unique.end());
  unique.erase(std::unique(unique.begin(), unique.end()), unique.end());
  std::vector<CellObservation> obs;
  obs.reserve(unique.size());
  for (int cell : unique) {
    if (!grid_.IsValidCell(cell)) {
      return absl::InvalidArgumentError(
          absl::StrCat("cells: ", cell, " is outside [0, ", num_cells(), ")"));
    }
    obs.push_back({.cell = cell, .value = 0.0, .variance = kNearCertainVariance});
  }
  return Update(obs);
}

}  // namespace oaipp
