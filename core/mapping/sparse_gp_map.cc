#include "core/mapping/sparse_gp_map.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "cholmod.h"
#include "core/common/status_macros.h"

// The reference BLAS interface (Fortran symbols), as CHOLMOD itself calls
// it: Debian resolves libblas.so.3 to OpenBLAS when it is installed, with
// kernels for the CPU at hand, where Eigen's own product is built for
// generic x86-64.
extern "C" void dgemm_(const char* transa, const char* transb, const int* m, const int* n,
                       const int* k, const double* alpha, const double* a, const int* lda,
                       const double* b, const int* ldb, const double* beta, double* c,
                       const int* ldc);

namespace oaipp {

// CHOLMOD's workspace and the factor, freed together.
struct SparseGpMap::Cholmod {
  cholmod_common common{};
  cholmod_factor* factor = nullptr;

  Cholmod() {
    cholmod_start(&common);
    // Always supernodal: the selected inversion works on its dense blocks.
    common.supernodal = CHOLMOD_SUPERNODAL;
  }
  ~Cholmod() {
    if (factor != nullptr) cholmod_free_factor(&factor, &common);
    cholmod_finish(&common);
  }
  Cholmod(const Cholmod&) = delete;
  Cholmod& operator=(const Cholmod&) = delete;
};

namespace {

// A view of the lower triangle `q` as CHOLMOD's symmetric matrix (CHOLMOD
// takes it non-const but only reads it).
cholmod_sparse View(const Eigen::SparseMatrix<double, Eigen::ColMajor, int>& q) {
  cholmod_sparse a{};
  a.nrow = static_cast<std::size_t>(q.rows());
  a.ncol = static_cast<std::size_t>(q.cols());
  a.nzmax = static_cast<std::size_t>(q.nonZeros());
  a.p = const_cast<int*>(q.outerIndexPtr());
  a.i = const_cast<int*>(q.innerIndexPtr());
  a.x = const_cast<double*>(q.valuePtr());
  a.stype = -1;  // lower triangle of a symmetric matrix
  a.itype = CHOLMOD_INT;
  a.xtype = CHOLMOD_REAL;
  a.dtype = CHOLMOD_DOUBLE;
  a.sorted = 1;
  a.packed = 1;
  return a;
}

// diag((L L^T)^-1) from CHOLMOD's supernodal factor, by the Takahashi
// recursion a supernode at a time, from the last. For a supernode S (its
// own columns, lower-triangular block L_SS) with rows R below it (block
// L_RS), and U = L_RS L_SS^-1:
//   Z_RS = -Z_RR U,    Z_SS = L_SS^-T L_SS^-1 - U^T Z_RS,
// where Z = (L L^T)^-1. Every entry of Z_RR lies in the pattern of a later
// supernode (the filled graph is chordal), so Z is kept in L's own layout
// and Z_RR gathered from it. Returns the diagonal in pivot order.
Eigen::VectorXd SupernodalTakahashiDiagonal(const cholmod_factor& f) {
  using Eigen::MatrixXd;
  const int n = static_cast<int>(f.n);
  const int nsuper = static_cast<int>(f.nsuper);
  const int* super = static_cast<const int*>(f.super);
  const int* pi = static_cast<const int*>(f.pi);
  const int* px = static_cast<const int*>(f.px);
  const int* rows = static_cast<const int*>(f.s);
  const double* lx = static_cast<const double*>(f.x);
  std::vector<int> super_of(n);
  for (int t = 0; t < nsuper; ++t) {
    for (int k = super[t]; k < super[t + 1]; ++k) super_of[k] = t;
  }
  std::vector<double> z(f.xsize, 0.0);
  std::vector<int> pos;
  MatrixXd zrr, u, zrs, inverse, inverse_product;
  Eigen::VectorXd diagonal(n);
  for (int t = nsuper - 1; t >= 0; --t) {
    const int w = super[t + 1] - super[t];
    const int nr = pi[t + 1] - pi[t];
    const int r = nr - w;
    const int* below = rows + pi[t] + w;
    const Eigen::Map<const MatrixXd> l(lx + px[t], nr, w);
    // Gather Z_RR (lower triangle, then mirrored), one later supernode at a
    // time: R's columns in supernode T are consecutive, and the rows of R
    // from there on all lie in T's row list.
    zrr.resize(r, r);
    for (int b = 0; b < r;) {
      const int tt = super_of[below[b]];
      const int* t_rows = rows + pi[tt];
      const int t_nr = pi[tt + 1] - pi[tt];
      int e = b;
      while (e < r && below[e] < super[tt + 1]) ++e;
      pos.resize(r - b);
      for (int q = b, p = 0; q < r; ++q) {
        while (t_rows[p] < below[q]) ++p;
        pos[q - b] = p;
      }
      for (int a = b; a < e; ++a) {
        const double* column =
            z.data() + px[tt] + static_cast<std::size_t>(below[a] - super[tt]) * t_nr;
        for (int q = a; q < r; ++q) zrr(q, a) = column[pos[q - b]];
      }
      b = e;
    }
    zrr.triangularView<Eigen::StrictlyUpper>() = zrr.transpose();
    const auto lss = l.topRows(w).triangularView<Eigen::Lower>();
    inverse = lss.solve(MatrixXd::Identity(w, w));
    Eigen::Map<MatrixXd> zt(z.data() + px[t], nr, w);
    if (r > 0) {
      // u = L_RS L_SS^-1, zrs = -zrr u and Z_SS -= u^T zrs: the products
      // that cost, on BLAS.
      const double minus_one = -1.0, one = 1.0, zero = 0.0;
      u.resize(r, w);
      zrs.resize(r, w);
      dgemm_("N", "N", &r, &w, &w, &one, lx + px[t] + w, &nr, inverse.data(), &w, &zero, u.data(),
             &r);
      dgemm_("N", "N", &r, &w, &r, &minus_one, zrr.data(), &r, u.data(), &r, &zero, zrs.data(), &r);
      zt.bottomRows(r) = zrs;
      inverse_product.noalias() = inverse.transpose() * inverse;
      dgemm_("T", "N", &w, &w, &r, &minus_one, u.data(), &r, zrs.data(), &r, &one,
             inverse_product.data(), &w);
      zt.topRows(w) = inverse_product;
    } else {
      zt.topRows(w).noalias() = inverse.transpose() * inverse;
    }
    for (int k = 0; k < w; ++k) diagonal[super[t] + k] = zt(k, k);
  }
  return diagonal;
}

}  // namespace

SparseGpMap::SparseGpMap(const FieldGrid& grid, GmrfPrior prior)
    : grid_(grid),
      prior_(std::move(prior)),
      precision_(prior_.precision),
      information_(prior_.information),
      added_precision_(Eigen::VectorXd::Zero(grid.num_cells())),
      added_information_(Eigen::VectorXd::Zero(grid.num_cells())),
      cholmod_(std::make_unique<Cholmod>()) {
  const int n = prior_.num_states();
  diagonal_.resize(n);
  for (int s = 0; s < n; ++s) {
    // Lower triangle, sorted: the diagonal is each column's first entry.
    diagonal_[s] = precision_.outerIndexPtr()[s];
  }
}

SparseGpMap::SparseGpMap(SparseGpMap&&) noexcept = default;
SparseGpMap& SparseGpMap::operator=(SparseGpMap&&) noexcept = default;
SparseGpMap::~SparseGpMap() = default;

absl::StatusOr<SparseGpMap> SparseGpMap::Create(const FieldGrid& grid, const GpParams& params,
                                                const GmrfOptions& options) {
  OAIPP_ASSIGN_OR_RETURN(GmrfPrior prior, MakeGmrfPrior(grid, params, options));
  return FromPrior(grid, std::move(prior));
}

absl::StatusOr<SparseGpMap> SparseGpMap::FromPrior(const FieldGrid& grid, GmrfPrior prior,
                                                   Factorise factorise) {
  const int n = prior.num_states();
  if (static_cast<int>(prior.field_state.size()) != grid.num_cells()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "prior: ", prior.field_state.size(), " field cells, the grid has ", grid.num_cells()));
  }
  if (prior.precision.rows() != n || prior.precision.cols() != n || prior.information.size() != n) {
    return absl::InvalidArgumentError("prior: precision and information must be states x states");
  }
  for (int s : prior.field_state) {
    if (s < 0 || s >= n)
      return absl::InvalidArgumentError("prior: a field cell's state is out of range");
  }
  prior.precision.makeCompressed();
  for (int s = 0; s < n; ++s) {
    const int first = prior.precision.outerIndexPtr()[s];
    if (first == prior.precision.outerIndexPtr()[s + 1] ||
        prior.precision.innerIndexPtr()[first] != s) {
      return absl::InvalidArgumentError(
          absl::StrCat("prior: state ", s, " has no diagonal entry in the lower triangle"));
    }
  }
  SparseGpMap map(grid, std::move(prior));
  map.dirty_ = true;
  if (factorise == Factorise::kNow) OAIPP_RETURN_IF_ERROR(map.Refresh());
  return map;
}

absl::Status SparseGpMap::Refresh() const {
  if (!dirty_) return absl::OkStatus();
  cholmod_common& c = cholmod_->common;
  cholmod_sparse a = View(precision_);
  if (cholmod_->factor == nullptr) {
    cholmod_->factor = cholmod_analyze(&a, &c);
    if (cholmod_->factor == nullptr || c.status != CHOLMOD_OK) {
      return absl::InternalError(absl::StrCat("CHOLMOD analysis failed (status ", c.status, ")"));
    }
  }
  if (!cholmod_factorize(&a, cholmod_->factor, &c) || c.status != CHOLMOD_OK) {
    return absl::InternalError(absl::StrCat("CHOLMOD factorisation failed (status ", c.status,
                                            "): the precision is not positive definite"));
  }
  cholmod_dense b{};
  b.nrow = b.d = b.nzmax = static_cast<std::size_t>(information_.size());
  b.ncol = 1;
  b.x = const_cast<double*>(information_.data());  // only read
  b.xtype = CHOLMOD_REAL;
  b.dtype = CHOLMOD_DOUBLE;
  cholmod_dense* x = cholmod_solve(CHOLMOD_A, cholmod_->factor, &b, &c);
  if (x == nullptr) return absl::InternalError("CHOLMOD solve failed");
  const double* xs = static_cast<const double*>(x->x);
  mean_.resize(grid_.num_cells());
  for (int cell = 0; cell < grid_.num_cells(); ++cell) mean_[cell] = xs[prior_.field_state[cell]];
  cholmod_free_dense(&x, &c);
  variances_.reset();
  dirty_ = false;
  return absl::OkStatus();
}

absl::Status SparseGpMap::Update(std::span<const CellObservation> observations) {
  OAIPP_ASSIGN_OR_RETURN(std::vector<CellObservation> merged,
                         MergeObservations(observations, num_cells()));
  if (merged.empty()) return absl::OkStatus();
  double* values = precision_.valuePtr();
  for (const CellObservation& o : merged) {
    const int s = prior_.field_state[o.cell];
    const double precision = 1.0 / o.variance;
    values[diagonal_[s]] += precision;
    information_[s] += o.value * precision;
    added_precision_[o.cell] += precision;
    added_information_[o.cell] += o.value * precision;
  }
  dirty_ = true;
  return absl::OkStatus();
}

std::vector<CellObservation> SparseGpMap::NearCertainZeros(std::span<const int> cells) {
  std::vector<int> sorted(cells.begin(), cells.end());
  std::sort(sorted.begin(), sorted.end());
  sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
  std::vector<CellObservation> zeros;
  zeros.reserve(sorted.size());
  for (int cell : sorted) {
    zeros.push_back({.cell = cell, .value = 0.0, .variance = GpMap::kNearCertainVariance});
  }
  return zeros;
}

absl::Status SparseGpMap::FuseNearCertainZeros(std::span<const int> cells) {
  return Update(NearCertainZeros(cells));
}

SparseGpMap::Additions SparseGpMap::NoAdditions(int num_cells) {
  return {.precision = Eigen::VectorXd::Zero(num_cells),
          .information = Eigen::VectorXd::Zero(num_cells)};
}

absl::Status SparseGpMap::Accumulate(std::span<const CellObservation> observations,
                                     Additions& added) {
  if (added.precision.size() != added.information.size()) {
    return absl::InvalidArgumentError("added: precision and information differ in size");
  }
  OAIPP_ASSIGN_OR_RETURN(std::vector<CellObservation> merged,
                         MergeObservations(observations, static_cast<int>(added.precision.size())));
  // As Update does, one cell at a time.
  for (const CellObservation& o : merged) {
    const double precision = 1.0 / o.variance;
    added.precision[o.cell] += precision;
    added.information[o.cell] += o.value * precision;
  }
  return absl::OkStatus();
}

absl::StatusOr<Eigen::VectorXd> SparseGpMap::Mean() const {
  OAIPP_RETURN_IF_ERROR(Refresh());
  return mean_;
}

absl::StatusOr<Eigen::VectorXd> SparseGpMap::Variances() const {
  OAIPP_RETURN_IF_ERROR(Refresh());
  if (variances_ != nullptr) return *variances_;
  const cholmod_factor& f = *cholmod_->factor;
  const Eigen::VectorXd pivoted = SupernodalTakahashiDiagonal(f);
  Eigen::VectorXd states(pivoted.size());
  const int* perm = static_cast<const int*>(f.Perm);
  for (Eigen::Index k = 0; k < pivoted.size(); ++k) states[perm[k]] = pivoted[k];
  auto field = std::make_unique<Eigen::VectorXd>(grid_.num_cells());
  for (int cell = 0; cell < grid_.num_cells(); ++cell) {
    (*field)[cell] = states[prior_.field_state[cell]];
  }
  variances_ = std::move(field);
  return *variances_;
}

absl::StatusOr<double> SparseGpMap::Trace() const {
  OAIPP_ASSIGN_OR_RETURN(Eigen::VectorXd variances, Variances());
  return variances.sum();
}

absl::Status SparseGpMap::CheckAdditions(const Eigen::VectorXd& added_precision,
                                         const Eigen::VectorXd& added_information) {
  const Eigen::Index n = std::min(added_precision.size(), added_information.size());
  for (Eigen::Index cell = 0; cell < n; ++cell) {
    if (!(added_precision[cell] >= 0.0) || !std::isfinite(added_precision[cell]) ||
        !std::isfinite(added_information[cell])) {
      return absl::InvalidArgumentError(
          absl::StrCat("state: cell ", cell, " has a negative or non-finite addition"));
    }
  }
  return absl::OkStatus();
}

absl::Status SparseGpMap::Restore(const Eigen::VectorXd& added_precision,
                                  const Eigen::VectorXd& added_information) {
  if (added_precision.size() != num_cells() || added_information.size() != num_cells()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "state: the map has ", num_cells(), " cells, the snapshot ", added_precision.size()));
  }
  OAIPP_RETURN_IF_ERROR(CheckAdditions(added_precision, added_information));
  precision_ = prior_.precision;
  information_ = prior_.information;
  double* values = precision_.valuePtr();
  for (int cell = 0; cell < num_cells(); ++cell) {
    const int s = prior_.field_state[cell];
    values[diagonal_[s]] += added_precision[cell];
    information_[s] += added_information[cell];
  }
  added_precision_ = added_precision;
  added_information_ = added_information;
  dirty_ = true;
  return Refresh();
}

std::int64_t SparseGpMap::factor_nonzeros() const {
  const cholmod_factor* f = cholmod_->factor;
  if (f == nullptr) return 0;
  return static_cast<std::int64_t>(f->xsize);
}

std::int64_t SparseGpMap::bytes() const {
  const std::int64_t q = 2 * (12 * prior_.precision.nonZeros() + 4 * prior_.precision.cols());
  const std::int64_t vectors = 8 * (2 * prior_.num_states() + 4 * num_cells());
  // The factor, and Z in its layout while the variances are computed.
  return q + vectors + 16 * factor_nonzeros();
}

}  // namespace oaipp
