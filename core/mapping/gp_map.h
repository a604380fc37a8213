// The field map: a Gaussian process over the ground cells, updated by a
// Kalman filter (docs/method.md §3).
//
// The map holds the mean mu (n) and the dense covariance P (n x n) of the
// target field over the cells of a FieldGrid. It starts from the published
// code's prior P0 = K - K (K + sn2 I)^-1 K and fuses measurements with the
// Kalman update
//   S = P_JJ + R,  W = P_:J S^-1,  mu += W (z_J - mu_J),  P -= W P_J:
// over the observed cells J. The covariance update does not depend on z, so
// planners predict future covariance with the free functions below
// (UpdateCovariance, TraceAfterUpdate, VariancesAfterUpdate) without values.
//
// P is 8 n^2 bytes (20 MB for the paper's 1600 cells): GpMap is movable but
// copies only through Clone(), which shares P with the original until one of
// them changes it (copy on write). Many missions that start from one prior
// then hold one P until each fuses its first measurement, and a deferred
// update (UpdateDeferred) leaves P shared until it is settled: the 20 MB copy
// is paid where the downdate runs, not where the measurement arrives.
//
//   OAIPP_ASSIGN_OR_RETURN(FieldGrid grid, FieldGrid::FromBounds({-15, -15}, {15, 15}, 0.75));
//   OAIPP_ASSIGN_OR_RETURN(GpMap map, GpMap::Create(grid, GpParams::PaperPreset(0.75)));
//   OAIPP_RETURN_IF_ERROR(map.FuseNearCertainZeros(cells_under_buildings));
//   std::vector<CellObservation> obs = {{.cell = 17, .value = 1.0, .variance = 0.39}};
//   OAIPP_RETURN_IF_ERROR(map.Update(obs));
//   double trace = map.Trace();
//   // Planning: what would Tr(P) be after these (hypothetical) observations?
//   OAIPP_ASSIGN_OR_RETURN(double predicted, TraceAfterUpdate(map.Covariance(), obs));
#pragma once

#include <cassert>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "Eigen/Core"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/mapping/dense_backend.h"
#include "core/mapping/field_grid.h"
#include "core/mapping/gp_params.h"

namespace oaipp {

// One measured cell: value z (a label in [0, 1] for the target detector,
// though the filter accepts any finite value) with noise variance > 0.
struct CellObservation {
  int cell = 0;
  double value = 0.0;
  double variance = 1.0;
};

// Validates `observations` against a map of num_cells cells and merges
// repeated cells into one observation each: precision = sum of the
// precisions, value = the precision-weighted mean of the values. Fusing the
// merged list equals fusing the originals one by one, for the covariance and
// for the mean (independent Gaussian noise on one cell). The result is
// sorted by cell. InvalidArgument naming the entry and field when a cell is
// out of range, a variance is not positive and finite (or so small that its
// precision overflows), or (when check_values) a value is not finite; also
// when merging overflows. Without check_values the values are ignored and
// returned as 0 (covariance-only use).
[[nodiscard]] absl::StatusOr<std::vector<CellObservation>> MergeObservations(
    std::span<const CellObservation> observations, int num_cells, bool check_values = true);

// The dense map's largest field: its covariance is 8 n^2 bytes (800 MB at
// this size). Larger fields take the sparse map (core/mapping/sparse_gp_map.h).
inline constexpr std::int64_t kMaxDenseCells = 10'000;

// The published code's prior covariance P0 = K - K (K + sn2 I)^-1 K over the
// cell centres (docs/method.md §3), K_ij = Matern32(|c_i - c_j|), exactly
// symmetric. InvalidArgument when params are invalid; ResourceExhausted for
// a grid of more than kMaxDenseCells cells. Costs about n^3 flops
// (0.2-0.4 s for 1600 cells, mapping_bench).
[[nodiscard]] absl::StatusOr<Eigen::MatrixXd> PriorCovariance(const FieldGrid& grid,
                                                              const GpParams& params);

// Covariance-only Kalman update P -= P_:J S^-1 P_J: for planning: values are
// ignored (the covariance update does not depend on them, docs/method.md §3),
// repeated cells are merged as in MergeObservations. `covariance` must be
// square, symmetric and positive semi-definite. Returns InvalidArgument (as
// MergeObservations, or for a non-square matrix) and Internal when S is not
// positive definite (P was not PSD); on error `covariance` is unchanged.
// The three run their products on `backend` (Eigen by default).
[[nodiscard]] absl::Status UpdateCovariance(std::span<const CellObservation> observations,
                                            Eigen::MatrixXd& covariance,
                                            const DenseBackend& backend = DenseBackend());

// Tr(P) after the covariance-only update, without forming the updated P:
// Tr(P) - ||L^-1 P_J:||_F^2 with L L^T = S, O(n m^2) instead of O(n^2 m).
// Errors as UpdateCovariance.
[[nodiscard]] absl::StatusOr<double> TraceAfterUpdate(const Eigen::MatrixXd& covariance,
                                                      std::span<const CellObservation> observations,
                                                      const DenseBackend& backend = DenseBackend());

// The diagonal of P after the covariance-only update (per-cell predicted
// variances), O(n m^2). Errors as UpdateCovariance.
[[nodiscard]] absl::StatusOr<Eigen::VectorXd> VariancesAfterUpdate(
    const Eigen::MatrixXd& covariance, std::span<const CellObservation> observations,
    const DenseBackend& backend = DenseBackend());

class GpMap {
 public:
  // Variance given to the ground under obstacles by FuseNearCertainZeros.
  // Small against every real observation (var(2 m) = 0.095) and the prior
  // variances (0.23 .. 0.46 for the paper preset), so those cells end at mean
  // ~0 with standard deviation ~1e-3, i.e. certain for the planner. Not
  // smaller, because S = P_JJ + 1e-6 I must stay well conditioned for its
  // Cholesky factor: cond(S) <= 1 + Tr(P_JJ) / 1e-6, about 5e7 for a
  // 100-cell building, far from double precision's limit.
  static constexpr double kNearCertainVariance = 1e-6;

  // A map at the prior: mean params.prior_mean everywhere, covariance
  // PriorCovariance(grid, params). InvalidArgument for invalid params.
  [[nodiscard]] static absl::StatusOr<GpMap> Create(const FieldGrid& grid, const GpParams& params);

  // A map with a given prior (e.g. a plain GP prior K, or a cached P0).
  // InvalidArgument when the sizes do not match grid.num_cells(), an entry is
  // not finite, or covariance is not symmetric (to 1e-9 relative; it is then
  // made exactly symmetric).
  [[nodiscard]] static absl::StatusOr<GpMap> FromPrior(const FieldGrid& grid, Eigen::VectorXd mean,
                                                       Eigen::MatrixXd covariance);

  // Movable; a moved-from map may only be assigned to or destroyed.
  GpMap(GpMap&&) noexcept = default;
  GpMap& operator=(GpMap&&) noexcept = default;
  // The covariance is 8 n^2 bytes: copies are explicit.
  GpMap(const GpMap&) = delete;
  GpMap& operator=(const GpMap&) = delete;
  // A copy that shares the covariance until either map changes it. Two maps
  // that share it may be used from different threads (each map itself is not
  // thread-safe): the shared matrix is only read, and a change copies it.
  [[nodiscard]] GpMap Clone() const {
    GpMap copy(grid_, mean_, covariance_);
    copy.pending_ = pending_;
    copy.trace_after_pending_ = trace_after_pending_;
    copy.backend_ = backend_;
    return copy;
  }
  // Makes the covariance this map's own now (copying it when shared), for a
  // caller that chooses where the copy's time is spent (the benchmarks).
  void Unshare();
  // Whether another map still shares this one's covariance (a hint: another
  // thread may let go of it at any time).
  [[nodiscard]] bool shares_covariance() const { return covariance_.use_count() > 1; }

  // Where the updates' dense products run (core/mapping/dense_backend.h):
  // Eigen unless set. Results differ between backends in the last bits.
  void set_dense_backend(const DenseBackend& backend) { backend_ = backend; }
  [[nodiscard]] const DenseBackend& dense_backend() const { return backend_; }

  // Fuses `observations` in one Kalman update (docs/method.md §3), repeated
  // cells merged first (MergeObservations). An empty span does nothing.
  // Everything is validated before the map changes: on error the map is
  // untouched. InvalidArgument naming the entry and field ("observations[2].
  // variance: ..."); Internal if S is not positive definite (cannot happen
  // while P is PSD).
  [[nodiscard]] absl::Status Update(std::span<const CellObservation> observations);

  // Fuses value 0 with variance kNearCertainVariance at each of `cells`: the
  // ground under an obstacle's footprint cannot hold targets (docs/method.md
  // §3.7). The caller does this once per obstacle (fusing twice halves the
  // variance again, harmlessly). Repeated cells count once. Errors as Update.
  [[nodiscard]] absl::Status FuseNearCertainZeros(std::span<const int> cells);

  // Update in two halves, for a caller that answers before the expensive
  // one: the mean, the trace and the factor of the update now (O(n m^2)),
  // the covariance's rank-m downdate P -= Bt Bt^T (O(n^2 m), most of the
  // work for a shot that sees a small part of the field) on Settle. Once
  // settled the map is bit for bit what Update gives. Until then
  // Covariance(), Variance() and Variances() must not be read (Settle
  // first); Mean() and Trace() already include the update. On OpenBLAS a
  // shot that sees at least half the field is fused whole (it takes another
  // route there, core/mapping/dense_backend.h). A pending downdate is
  // settled before any further update. Errors as Update.
  [[nodiscard]] absl::Status UpdateDeferred(std::span<const CellObservation> observations);
  // Applies a pending downdate; nothing when there is none.
  void Settle();
  [[nodiscard]] bool settled() const { return pending_.size() == 0; }

  [[nodiscard]] const FieldGrid& grid() const { return grid_; }
  [[nodiscard]] int num_cells() const { return static_cast<int>(mean_.size()); }
  [[nodiscard]] const Eigen::VectorXd& Mean() const { return mean_; }
  // Precondition of the three: settled().
  [[nodiscard]] const Eigen::MatrixXd& Covariance() const {
    assert(settled());
    return *covariance_;
  }
  // Posterior variance of one cell. Precondition: grid().IsValidCell(cell).
  [[nodiscard]] double Variance(int cell) const {
    assert(settled());
    return (*covariance_)(cell, cell);
  }
  [[nodiscard]] Eigen::VectorXd Variances() const {
    assert(settled());
    return covariance_->diagonal();
  }
  // Tr(P), the map's total uncertainty (the non-adaptive objective). With a
  // downdate pending: Tr(P) - |Bt|_F^2, equal to the settled trace up to
  // rounding.
  [[nodiscard]] double Trace() const {
    return settled() ? covariance_->trace() : trace_after_pending_;
  }

 private:
  GpMap(const FieldGrid& grid, Eigen::VectorXd mean, Eigen::MatrixXd covariance)
      : grid_(grid),
        mean_(std::move(mean)),
        covariance_(std::make_shared<Eigen::MatrixXd>(std::move(covariance))) {}
  GpMap(const FieldGrid& grid, Eigen::VectorXd mean, std::shared_ptr<Eigen::MatrixXd> covariance)
      : grid_(grid), mean_(std::move(mean)), covariance_(std::move(covariance)) {}

  // The covariance to write its lower triangle, this map's own: a shared one
  // is first copied (its lower triangle only, what the rank downdates read;
  // the caller writes the upper one, MirrorLowerToUpper).
  Eigen::MatrixXd& OwnLowerTriangle();

  // Update, or UpdateDeferred with `defer_downdate`.
  absl::Status Fuse(std::span<const CellObservation> observations, bool defer_downdate);

  FieldGrid grid_;
  Eigen::VectorXd mean_;
  // Never null but in a moved-from map; written only while this map is its
  // only holder (use_count() == 1), so a map that shares it never sees it
  // change.
  std::shared_ptr<Eigen::MatrixXd> covariance_;
  // Bt (n x m) of an update whose downdate is pending; empty when settled.
  Eigen::MatrixXd pending_;
  double trace_after_pending_ = 0.0;
  DenseBackend backend_;
};

}  // namespace oaipp
