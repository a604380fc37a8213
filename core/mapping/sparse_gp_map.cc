#include "core/mapping/sparse_gp_map.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "cholmod.h"
#include "core/common/status_macros.h"

namespace oaipp {

// CHOLMOD's workspace and the factor, freed together.
struct SparseGpMap::Cholmod {
  cholmod_common common{};
  cholmod_factor* factor = nullptr;

  Cholmod() { cholmod_start(&common); }
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

// diag((L L^T)^-1) from a simplicial, packed LL^T factor by the Takahashi
// recursion, column by column from the last: for each column j with
// off-diagonal rows R (all > j),
//   Z_ij = -(1 / L_jj) sum_{k in R} L_kj Z_ik    (i in R)
//   Z_jj = 1 / L_jj^2 - (1 / L_jj) sum_{k in R} L_kj Z_kj,
// where every Z_ik needed lies in L's pattern (the filled graph is chordal).
// Z is kept on that pattern only. Returns the diagonal in pivot order.
Eigen::VectorXd TakahashiDiagonal(const cholmod_factor& f) {
  const int n = static_cast<int>(f.n);
  const int* p = static_cast<const int*>(f.p);
  const int* rows = static_cast<const int*>(f.i);
  const double* lx = static_cast<const double*>(f.x);
  std::vector<double> z(static_cast<std::size_t>(p[n]), 0.0);
  // Z(i, k) for i > k: in column k at row i.
  auto at = [&](int i, int k) -> double {
    if (i == k) return z[p[k]];
    if (i < k) std::swap(i, k);
    const int* begin = rows + p[k] + 1;
    const int* end = rows + p[k + 1];
    const int* hit = std::lower_bound(begin, end, i);
    return z[hit - rows];
  };
  std::vector<double> acc;
  for (int j = n - 1; j >= 0; --j) {
    const int first = p[j] + 1, last = p[j + 1];
    const int m = last - first;
    const double ljj = lx[p[j]];
    acc.assign(m, 0.0);
    for (int a = 0; a < m; ++a) {
      const int ra = rows[first + a];
      const double la = lx[first + a];
      acc[a] += la * z[p[ra]];
      for (int b = a + 1; b < m; ++b) {
        const int rb = rows[first + b];
        const double zab = at(rb, ra);
        acc[a] += lx[first + b] * zab;
        acc[b] += la * zab;
      }
    }
    double sum = 0.0;
    for (int a = 0; a < m; ++a) {
      z[first + a] = -acc[a] / ljj;
      sum += lx[first + a] * z[first + a];
    }
    z[p[j]] = 1.0 / (ljj * ljj) - sum / ljj;
  }
  Eigen::VectorXd diagonal(n);
  for (int j = 0; j < n; ++j) diagonal[j] = z[p[j]];
  return diagonal;
}

// Sorts the rows of each column of a packed simplicial factor (with the
// diagonal first), which the recursion's lookups need.
void SortColumns(cholmod_factor& f) {
  const int n = static_cast<int>(f.n);
  const int* p = static_cast<const int*>(f.p);
  int* rows = static_cast<int*>(f.i);
  double* x = static_cast<double*>(f.x);
  std::vector<std::pair<int, double>> column;
  for (int j = 0; j < n; ++j) {
    const int first = p[j] + 1, last = p[j + 1];
    if (std::is_sorted(rows + first, rows + last)) continue;
    column.clear();
    for (int k = first; k < last; ++k) column.emplace_back(rows[k], x[k]);
    std::sort(column.begin(), column.end());
    for (int k = first; k < last; ++k) std::tie(rows[k], x[k]) = column[k - first];
  }
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

absl::StatusOr<SparseGpMap> SparseGpMap::FromPrior(const FieldGrid& grid, GmrfPrior prior) {
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
  OAIPP_RETURN_IF_ERROR(map.Refresh());
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

absl::Status SparseGpMap::FuseNearCertainZeros(std::span<const int> cells) {
  std::vector<CellObservation> zeros;
  zeros.reserve(cells.size());
  std::vector<int> sorted(cells.begin(), cells.end());
  std::sort(sorted.begin(), sorted.end());
  sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
  for (int cell : sorted) {
    zeros.push_back({.cell = cell, .value = 0.0, .variance = GpMap::kNearCertainVariance});
  }
  return Update(zeros);
}

absl::StatusOr<Eigen::VectorXd> SparseGpMap::Mean() const {
  OAIPP_RETURN_IF_ERROR(Refresh());
  return mean_;
}

absl::StatusOr<Eigen::VectorXd> SparseGpMap::Variances() const {
  OAIPP_RETURN_IF_ERROR(Refresh());
  if (variances_ != nullptr) return *variances_;
  cholmod_common& c = cholmod_->common;
  cholmod_factor* f = cholmod_copy_factor(cholmod_->factor, &c);
  if (f == nullptr) return absl::ResourceExhaustedError("CHOLMOD: no memory to copy the factor");
  if (!cholmod_change_factor(CHOLMOD_REAL, /*to_ll=*/1, /*to_super=*/0, /*to_packed=*/1,
                             /*to_monotonic=*/1, f, &c)) {
    cholmod_free_factor(&f, &c);
    return absl::InternalError("CHOLMOD could not convert the factor");
  }
  SortColumns(*f);
  const Eigen::VectorXd pivoted = TakahashiDiagonal(*f);
  Eigen::VectorXd states(pivoted.size());
  const int* perm = static_cast<const int*>(f->Perm);
  for (Eigen::Index k = 0; k < pivoted.size(); ++k) states[perm[k]] = pivoted[k];
  cholmod_free_factor(&f, &c);
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

absl::Status SparseGpMap::Restore(const Eigen::VectorXd& added_precision,
                                  const Eigen::VectorXd& added_information) {
  if (added_precision.size() != num_cells() || added_information.size() != num_cells()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "state: the map has ", num_cells(), " cells, the snapshot ", added_precision.size()));
  }
  for (int cell = 0; cell < num_cells(); ++cell) {
    if (!(added_precision[cell] >= 0.0) || !std::isfinite(added_precision[cell]) ||
        !std::isfinite(added_information[cell])) {
      return absl::InvalidArgumentError(
          absl::StrCat("state: cell ", cell, " has a negative or non-finite addition"));
    }
  }
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
  return static_cast<std::int64_t>(f->is_super ? f->xsize : f->nzmax);
}

std::int64_t SparseGpMap::bytes() const {
  const std::int64_t q = 2 * (12 * prior_.precision.nonZeros() + 4 * prior_.precision.cols());
  const std::int64_t vectors = 8 * (2 * prior_.num_states() + 4 * num_cells());
  return q + vectors + 12 * factor_nonzeros();
}

}  // namespace oaipp
