#include "core/mapping/sparse_gp_map.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numeric>
#include <thread>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "cholmod.h"
#include "core/common/status_macros.h"
#include "core/mapping/dense_backend.h"

// The reference BLAS and LAPACK interfaces (Fortran symbols), as CHOLMOD
// itself calls them: Debian resolves libblas.so.3 to OpenBLAS when it is
// installed, with kernels for the CPU at hand, where Eigen's own product is
// built for generic x86-64.
extern "C" {
void dgemm_(const char* transa, const char* transb, const int* m, const int* n, const int* k,
            const double* alpha, const double* a, const int* lda, const double* b, const int* ldb,
            const double* beta, double* c, const int* ldc);
void dsymm_(const char* side, const char* uplo, const int* m, const int* n, const double* alpha,
            const double* a, const int* lda, const double* b, const int* ldb, const double* beta,
            double* c, const int* ldc);
void dtrsm_(const char* side, const char* uplo, const char* transa, const char* diag, const int* m,
            const int* n, const double* alpha, const double* a, const int* lda, double* b,
            const int* ldb);
// LAPACK: a triangular matrix's inverse, and L^T L of a lower triangle, in place.
void dtrtri_(const char* uplo, const char* diag, const int* n, double* a, const int* lda,
             int* info);
void dlauum_(const char* uplo, const int* n, double* a, const int* lda, int* info);
}

namespace oaipp {

// CHOLMOD's workspace and the factor, freed together, and the selected
// inversion's workspace: Z in the factor's layout, as large as the factor
// and kept between calls. Allocated afresh for each variance map, its first
// touch alone cost 0.47 s at 90,000 cells on a 2-core virtual machine (page
// faults), about as much as the inversion's arithmetic.
struct SparseGpMap::Cholmod {
  cholmod_common common{};
  cholmod_factor* factor = nullptr;
  std::vector<double> z;

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
// recursion a supernode at a time, each after every supernode above it. For
// a supernode S (its own columns, lower-triangular block L_SS) with rows R
// below it (block L_RS), and U = L_RS L_SS^-1:
//   Z_RS = -Z_RR U,    Z_SS = L_SS^-T L_SS^-1 - U^T Z_RS,
// where Z = (L L^T)^-1. Every entry of Z_RR lies in the pattern of a
// supernode above S (the filled graph is chordal), so Z is kept in L's own
// layout and Z_RR gathered from it; only lower triangles are ever read.
// Supernodes in disjoint subtrees of the supernodal elimination tree read
// and write disjoint parts of Z, so below the top of the tree two threads
// take a share of the subtrees each. Every entry of Z is written before it
// is read, so `z` may come in holding an earlier call's values. Returns the
// diagonal in pivot order.
// The threads OpenBLAS runs its products on (1 without OpenBLAS). With
// more than one, two threads of ours calling it at once contend for them
// (three times slower, measured at 90,000 cells): the tree then runs in one
// thread and the products in OpenBLAS's.
int BlasThreads() { return ReadBlasFacts().threads; }

class Takahashi {
 public:
  Takahashi(const cholmod_factor& f, std::vector<double>& z)
      : n_(static_cast<int>(f.n)),
        nsuper_(static_cast<int>(f.nsuper)),
        super_(static_cast<const int*>(f.super)),
        pi_(static_cast<const int*>(f.pi)),
        px_(static_cast<const int*>(f.px)),
        rows_(static_cast<const int*>(f.s)),
        lx_(static_cast<const double*>(f.x)),
        super_of_(n_),
        z_(z),
        diagonal_(n_) {
    z_.resize(f.xsize);
    for (int t = 0; t < nsuper_; ++t) {
      for (int k = super_[t]; k < super_[t + 1]; ++k) super_of_[k] = t;
    }
  }

  Eigen::VectorXd Run() {
    // The tree: a supernode's parent holds the first row below its own
    // columns. CHOLMOD numbers supernodes in postorder, so a subtree is the
    // range [first, root]; checked, and without it everything runs in order.
    std::vector<int> parent(nsuper_, -1), first(nsuper_);
    std::vector<double> cost(nsuper_);
    std::vector<std::vector<int>> children(nsuper_);
    std::vector<int> roots;
    for (int t = 0; t < nsuper_; ++t) first[t] = t;
    bool postorder = true;
    for (int t = 0; t < nsuper_; ++t) {
      const double w = super_[t + 1] - super_[t];
      const double r = pi_[t + 1] - pi_[t] - w;
      cost[t] += r * r * w + 2 * r * w * w + w * w * w + r * r;
      if (r > 0) {
        parent[t] = super_of_[rows_[pi_[t] + static_cast<int>(w)]];
        postorder = postorder && parent[t] > t;
        if (!postorder) break;
        first[parent[t]] = std::min(first[parent[t]], first[t]);
        cost[parent[t]] += cost[t];
        children[parent[t]].push_back(t);
      } else {
        roots.push_back(t);
      }
    }
    // A postorder: each subtree's size is the length of its range.
    std::vector<int> size(nsuper_, 1);
    for (int t = 0; postorder && t < nsuper_; ++t) {
      if (parent[t] >= 0) size[parent[t]] += size[t];
      postorder = size[t] == t - first[t] + 1;
    }
    Scratch main;
    if (!postorder || BlasThreads() > 1) {
      for (int t = nsuper_ - 1; t >= 0; --t) Supernode(t, main);
      return diagonal_;
    }
    // The top of the tree in order, largest subtree first, until no subtree
    // left holds more than half of what remains; then those subtrees shared
    // by two threads, largest first to the one with less.
    std::vector<int> frontier = roots;
    const auto by_cost = [&](int a, int b) { return cost[a] < cost[b]; };
    while (!frontier.empty()) {
      const auto largest = std::max_element(frontier.begin(), frontier.end(), by_cost);
      double total = 0;
      for (int t : frontier) total += cost[t];
      if (cost[*largest] <= total / 2 && frontier.size() >= 2) break;
      const int t = *largest;
      frontier.erase(largest);
      Supernode(t, main);
      frontier.insert(frontier.end(), children[t].begin(), children[t].end());
    }
    std::sort(frontier.begin(), frontier.end(), [&](int a, int b) { return cost[a] > cost[b]; });
    std::vector<int> shares[2];
    double load[2] = {0, 0};
    for (int t : frontier) {
      const int k = load[0] <= load[1] ? 0 : 1;
      shares[k].push_back(t);
      load[k] += cost[t];
    }
    const auto run = [&](const std::vector<int>& subtrees, Scratch& scratch) {
      for (int root : subtrees) {
        for (int t = root; t >= first[root]; --t) Supernode(t, scratch);
      }
    };
    Scratch other;
    std::thread second([&] { run(shares[1], other); });
    run(shares[0], main);
    second.join();
    return diagonal_;
  }

  // Whether every diagonal block was inverted (false for a singular factor).
  [[nodiscard]] bool ok() const { return ok_; }

 private:
  struct Scratch {
    std::vector<int> pos;
    std::vector<double> zrr, u, zrs, zss;
  };

  void Supernode(int t, Scratch& s) {
    const int w = super_[t + 1] - super_[t];
    const int nr = pi_[t + 1] - pi_[t];
    const int r = nr - w;
    const int* below = rows_ + pi_[t] + w;
    const double* l = lx_ + px_[t];
    const double one = 1.0, minus_one = -1.0, zero = 0.0;
    // Gather Z_RR's lower triangle, one supernode above at a time: R's
    // columns in supernode T are consecutive, and the rows of R from there
    // on all lie in T's row list.
    s.zrr.resize(static_cast<std::size_t>(r) * r);  // its lower triangle is written and read
    for (int b = 0; b < r;) {
      const int tt = super_of_[below[b]];
      const int* t_rows = rows_ + pi_[tt];
      const int t_nr = pi_[tt + 1] - pi_[tt];
      int e = b;
      while (e < r && below[e] < super_[tt + 1]) ++e;
      s.pos.resize(r - b);
      for (int q = b, p = 0; q < r; ++q) {
        while (t_rows[p] < below[q]) ++p;
        s.pos[q - b] = p;
      }
      for (int a = b; a < e; ++a) {
        const double* column =
            z_.data() + px_[tt] + static_cast<std::size_t>(below[a] - super_[tt]) * t_nr;
        double* out = s.zrr.data() + static_cast<std::size_t>(a) * r;
        for (int q = a; q < r; ++q) out[q] = column[s.pos[q - b]];
      }
      b = e;
    }
    // Z_SS's lower triangle starting as L_SS^-T L_SS^-1: LAPACK's
    // triangular inverse and its L^T L, in place (a third of the work of a
    // solve against the identity and a rank-k update).
    s.zss.assign(static_cast<std::size_t>(w) * w, 0.0);
    for (int k = 0; k < w; ++k) {
      std::copy_n(l + static_cast<std::size_t>(k) * nr + k, w - k,
                  s.zss.data() + static_cast<std::size_t>(k) * w + k);
    }
    int info = 0;
    dtrtri_("L", "N", &w, s.zss.data(), &w, &info);
    if (info == 0) dlauum_("L", &w, s.zss.data(), &w, &info);
    if (info != 0) ok_ = false;
    double* zt = z_.data() + px_[t];
    if (r > 0) {
      // U = L_RS L_SS^-1, Z_RS = -Z_RR U (Z_RR symmetric, its lower
      // triangle), Z_SS -= U^T Z_RS.
      s.u.resize(static_cast<std::size_t>(r) * w);
      for (int k = 0; k < w; ++k) {
        std::copy_n(l + static_cast<std::size_t>(k) * nr + w, r,
                    s.u.data() + static_cast<std::size_t>(k) * r);
      }
      dtrsm_("R", "L", "N", "N", &r, &w, &one, l, &nr, s.u.data(), &r);
      s.zrs.resize(static_cast<std::size_t>(r) * w);
      dsymm_("L", "L", &r, &w, &minus_one, s.zrr.data(), &r, s.u.data(), &r, &zero, s.zrs.data(),
             &r);
      dgemm_("T", "N", &w, &w, &r, &minus_one, s.u.data(), &r, s.zrs.data(), &r, &one, s.zss.data(),
             &w);
      for (int k = 0; k < w; ++k) {
        std::copy_n(s.zrs.data() + static_cast<std::size_t>(k) * r, r,
                    zt + static_cast<std::size_t>(k) * nr + w);
      }
    }
    for (int k = 0; k < w; ++k) {
      std::copy_n(s.zss.data() + static_cast<std::size_t>(k) * w, w,
                  zt + static_cast<std::size_t>(k) * nr);
      diagonal_[super_[t] + k] = s.zss[static_cast<std::size_t>(k) * w + k];
    }
  }

  const int n_;
  const int nsuper_;
  const int* const super_;
  const int* const pi_;
  const int* const px_;
  const int* const rows_;
  const double* const lx_;
  std::vector<int> super_of_;
  std::vector<double>& z_;
  Eigen::VectorXd diagonal_;
  std::atomic<bool> ok_{true};  // every diagonal block inverted (both threads write it)
};

absl::StatusOr<Eigen::VectorXd> SupernodalTakahashiDiagonal(const cholmod_factor& f,
                                                            std::vector<double>& z) {
  Takahashi takahashi(f, z);
  Eigen::VectorXd diagonal = takahashi.Run();
  if (!takahashi.ok()) {
    return absl::InternalError("selected inversion: a diagonal block of the factor is singular");
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
  // Its selected inversion calls the BLAS from two threads at once.
  OAIPP_RETURN_IF_ERROR(CheckBlasIsSafeForConcurrentCalls());
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
  OAIPP_ASSIGN_OR_RETURN(const Eigen::VectorXd pivoted,
                         SupernodalTakahashiDiagonal(f, cholmod_->z));
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
  // The factor, and Z in its layout (allocated by the first variance map
  // and kept).
  return q + vectors + 16 * factor_nonzeros();
}

}  // namespace oaipp
