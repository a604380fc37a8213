#include "core/mapping/field_window.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "Eigen/SparseCholesky"
#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"

namespace oaipp {

absl::StatusOr<FieldWindow> WindowAround(const FieldGrid& field, const Vec2& centre_W,
                                         double half_width_m) {
  if (!centre_W.allFinite()) return absl::InvalidArgumentError("centre_W: must be finite");
  if (!(half_width_m > 0.0) || !std::isfinite(half_width_m)) {
    return absl::InvalidArgumentError(
        absl::StrCat("half_width_m: must be positive and finite, got ", half_width_m));
  }
  const double h = field.resolution_m();
  const Vec2 centre = centre_W.cwiseMax(field.min_W()).cwiseMin(field.max_W());
  // In cells from the field's corner; a cell overlaps [lo, hi) when its
  // index lies in [floor(lo), ceil(hi)).
  const Vec2 lo = (centre - field.min_W()).array() / h - half_width_m / h;
  const Vec2 hi = (centre - field.min_W()).array() / h + half_width_m / h;
  const auto first = [](double v, int n) {
    return static_cast<int>(std::clamp(std::floor(v), 0.0, static_cast<double>(n - 1)));
  };
  const auto end = [](double v, int first_index, int n) {
    return static_cast<int>(
        std::clamp(std::ceil(v), static_cast<double>(first_index + 1), static_cast<double>(n)));
  };
  const int c0 = first(lo.x(), field.nx());
  const int r0 = first(lo.y(), field.ny());
  const int c1 = end(hi.x(), c0, field.nx());
  const int r1 = end(hi.y(), r0, field.ny());
  OAIPP_ASSIGN_OR_RETURN(FieldGrid grid,
                         FieldGrid::Create(field.min_W() + h * Vec2(c0, r0), c1 - c0, r1 - r0, h));
  FieldWindow window{.grid = grid, .first_row = r0, .first_col = c0, .field_cells = {}};
  window.field_cells.reserve(static_cast<std::size_t>(grid.num_cells()));
  for (int r = r0; r < r1; ++r) {
    for (int c = c0; c < c1; ++c) window.field_cells.push_back(field.Index(r, c));
  }
  return window;
}

namespace {

using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

// Where a lattice state goes in the window's system: the window W (its
// cells in the window's order), the margin M (row-major over W' minus W),
// or neither.
struct LocalIndex {
  enum Part { kOutside, kWindow, kMargin };
  Part part = kOutside;
  int index = -1;
};

class WindowLattice {
 public:
  WindowLattice(const GmrfPrior& prior, const FieldWindow& window, int margin_states)
      : lx_(prior.lattice_nx),
        // W in lattice coordinates, then W' = W widened by the margin.
        wc0_(window.first_col + prior.margin_cells),
        wr0_(window.first_row + prior.margin_cells),
        wc1_(wc0_ + window.grid.nx()),
        wr1_(wr0_ + window.grid.ny()),
        c0_(std::max(0, wc0_ - margin_states)),
        r0_(std::max(0, wr0_ - margin_states)),
        c1_(std::min(prior.lattice_nx, wc1_ + margin_states)),
        r1_(std::min(prior.lattice_ny, wr1_ + margin_states)) {
    // Margin states are numbered row by row; rows_before_[r - r0_] counts
    // those in the rows above r.
    margin_before_row_.reserve(static_cast<std::size_t>(r1_ - r0_ + 1));
    int count = 0;
    for (int r = r0_; r < r1_; ++r) {
      margin_before_row_.push_back(count);
      count += (c1_ - c0_) - ((r >= wr0_ && r < wr1_) ? (wc1_ - wc0_) : 0);
    }
    margin_size_ = count;
  }

  [[nodiscard]] int margin_size() const { return margin_size_; }
  [[nodiscard]] int window_size() const { return (wc1_ - wc0_) * (wr1_ - wr0_); }
  // The states of W', column range and rows, for walking Q's columns.
  [[nodiscard]] int first_row() const { return r0_; }
  [[nodiscard]] int end_row() const { return r1_; }
  [[nodiscard]] int first_col() const { return c0_; }
  [[nodiscard]] int end_col() const { return c1_; }
  [[nodiscard]] int State(int row, int col) const { return row * lx_ + col; }

  [[nodiscard]] LocalIndex Of(int state) const {
    const int r = state / lx_;
    const int c = state % lx_;
    if (r < r0_ || r >= r1_ || c < c0_ || c >= c1_) return {};
    if (r >= wr0_ && r < wr1_ && c >= wc0_ && c < wc1_) {
      return {.part = LocalIndex::kWindow, .index = (r - wr0_) * (wc1_ - wc0_) + (c - wc0_)};
    }
    int index = margin_before_row_[static_cast<std::size_t>(r - r0_)] + (c - c0_);
    if (r >= wr0_ && r < wr1_ && c >= wc1_) index -= wc1_ - wc0_;
    return {.part = LocalIndex::kMargin, .index = index};
  }

 private:
  int lx_, wc0_, wr0_, wc1_, wr1_, c0_, r0_, c1_, r1_;
  std::vector<int> margin_before_row_;
  int margin_size_ = 0;
};

}  // namespace

absl::StatusOr<GpMap> WindowMap(const SparseGpMap& map, const FieldWindow& window,
                                const FieldWindowOptions& options, const DenseBackend& backend) {
  if (!(options.margin_ranges >= 0.0) || !std::isfinite(options.margin_ranges)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "options.margin_ranges: must be >= 0 and finite, got ", options.margin_ranges));
  }
  const FieldGrid& field = map.grid();
  const FieldGrid& grid = window.grid;
  if (grid.resolution_m() != field.resolution_m() || window.first_row < 0 || window.first_col < 0 ||
      window.first_row + grid.ny() > field.ny() || window.first_col + grid.nx() > field.nx() ||
      static_cast<int>(window.field_cells.size()) != grid.num_cells()) {
    return absl::InvalidArgumentError("window: not a window of the map's field (WindowAround)");
  }
  if (grid.num_cells() > kMaxDenseCells) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "window: ", grid.num_cells(), " cells, the dense map holds at most ", kMaxDenseCells));
  }
  OAIPP_ASSIGN_OR_RETURN(Eigen::VectorXd field_mean, map.Mean());

  const GmrfPrior& prior = map.prior();
  const WindowLattice lattice(
      prior, window, static_cast<int>(std::ceil(options.margin_ranges * prior.fit.range_cells())));
  const int n = lattice.window_size();
  const int m = lattice.margin_size();

  // Q restricted to W', split into its blocks: S = Q_WW (dense, lower
  // triangle), Q_MM (sparse, lower triangle) and Q_MW (sparse).
  Eigen::MatrixXd s = Eigen::MatrixXd::Zero(n, n);
  std::vector<Eigen::Triplet<double>> mm;
  std::vector<Eigen::Triplet<double>> mw;
  const SparseMatrix& q = map.precision();
  for (int r = lattice.first_row(); r < lattice.end_row(); ++r) {
    for (int c = lattice.first_col(); c < lattice.end_col(); ++c) {
      const int column = lattice.State(r, c);
      const LocalIndex j = lattice.Of(column);
      for (SparseMatrix::InnerIterator it(q, column); it; ++it) {
        const LocalIndex i = lattice.Of(it.row());
        if (i.part == LocalIndex::kOutside) continue;
        const double v = it.value();
        if (i.part == LocalIndex::kWindow && j.part == LocalIndex::kWindow) {
          s(std::max(i.index, j.index), std::min(i.index, j.index)) = v;
        } else if (i.part == LocalIndex::kMargin && j.part == LocalIndex::kMargin) {
          mm.emplace_back(std::max(i.index, j.index), std::min(i.index, j.index), v);
        } else if (i.part == LocalIndex::kMargin) {
          mw.emplace_back(i.index, j.index, v);
        } else {
          mw.emplace_back(j.index, i.index, v);
        }
      }
    }
  }

  if (m > 0 && !mw.empty()) {
    // S -= Q_WM Q_MM^-1 Q_MW over the window cells B that touch the margin.
    std::vector<int> boundary_of(static_cast<std::size_t>(n), -1);
    std::vector<int> boundary;
    for (Eigen::Triplet<double>& t : mw) {
      int& b = boundary_of[static_cast<std::size_t>(t.col())];
      if (b < 0) {
        b = static_cast<int>(boundary.size());
        boundary.push_back(t.col());
      }
      t = Eigen::Triplet<double>(t.row(), b, t.value());
    }
    const int nb = static_cast<int>(boundary.size());
    SparseMatrix q_mm(m, m);
    q_mm.setFromTriplets(mm.begin(), mm.end());
    SparseMatrix q_mb(m, nb);
    q_mb.setFromTriplets(mw.begin(), mw.end());
    Eigen::SimplicialLLT<SparseMatrix, Eigen::Lower, Eigen::AMDOrdering<int>> llt(q_mm);
    if (llt.info() != Eigen::Success) {
      return absl::InternalError("window: the margin's precision is not positive definite");
    }
    const Eigen::MatrixXd x = llt.solve(Eigen::MatrixXd(q_mb));
    const Eigen::MatrixXd correction = q_mb.transpose() * x;
    for (int b = 0; b < nb; ++b) {
      for (int a = 0; a < nb; ++a) {
        const int i = boundary[static_cast<std::size_t>(a)];
        const int j = boundary[static_cast<std::size_t>(b)];
        if (i >= j) s(i, j) -= correction(a, b);
      }
    }
  }

  if (!backend.CholeskyLowerInPlace(s)) {
    return absl::InternalError("window: the window's precision is not positive definite");
  }
  backend.InverseFromCholeskyInPlace(s);
  s.triangularView<Eigen::StrictlyUpper>() = s.transpose();

  Eigen::VectorXd mean(n);
  for (int k = 0; k < n; ++k) mean[k] = field_mean[window.field_cells[static_cast<std::size_t>(k)]];
  OAIPP_ASSIGN_OR_RETURN(GpMap local, GpMap::FromPrior(grid, std::move(mean), std::move(s)));
  local.set_dense_backend(backend);
  return local;
}

}  // namespace oaipp
