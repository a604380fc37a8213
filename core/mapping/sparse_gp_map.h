// The field map for large fields: the same Kalman-exact inference as GpMap,
// in information form, on a prior with a sparse precision (GmrfPrior;
// docs/method.md §3.9).
//
// The map holds the precision Q (sparse, states x states) and the
// information vector b = Q mu. Fusing a per-cell observation (z, r) adds
// 1 / r to Q's diagonal and z / r to b: fusion is additive, so any order of
// the same observations gives the same map (up to rounding in b's sums), and
// never changes Q's pattern. Update does only that (O(cells seen)); the
// mean mu = Q^-1 b and the marginal variances diag(Q^-1) are computed when
// next asked for, from a sparse Cholesky factor of Q (CHOLMOD: one symbolic
// analysis for the map's life, one numeric factorisation per batch of
// updates), the variances by the Takahashi recursion over the factor's
// pattern. Nothing of size states^2 is ever formed. Not safe for concurrent
// use, const calls included (they refresh the factor).
//
// What it holds besides the prior (which MakeGmrfPrior rebuilds from the
// spec) is two vectors over the field: the precision fused at each cell and
// the information it added (AddedPrecision, AddedInformation), so a
// snapshot of a large map is 16 bytes a cell.
//
//   OAIPP_ASSIGN_OR_RETURN(SparseGpMap map, SparseGpMap::Create(grid, GpParams::PaperPreset(1.0)));
//   OAIPP_RETURN_IF_ERROR(map.Update({{.cell = 17, .value = 1.0, .variance = 0.39}}));
//   OAIPP_ASSIGN_OR_RETURN(Eigen::VectorXd mean, map.Mean());
//   OAIPP_ASSIGN_OR_RETURN(Eigen::VectorXd var, map.Variances());
#pragma once

#include <memory>
#include <span>
#include <vector>

#include "Eigen/Core"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/mapping/field_grid.h"
#include "core/mapping/gmrf_prior.h"
#include "core/mapping/gp_map.h"
#include "core/mapping/gp_params.h"

namespace oaipp {

class SparseGpMap {
 public:
  // A map at the prior MakeGmrfPrior(grid, params, options). Errors as
  // MakeGmrfPrior; Internal if the factorisation fails.
  [[nodiscard]] static absl::StatusOr<SparseGpMap> Create(const FieldGrid& grid,
                                                          const GpParams& params,
                                                          const GmrfOptions& options = {});
  // When FromPrior factorises: at once (a prior that is not positive
  // definite fails there), or on the first read (Mean, Variances), for a
  // prior known to be good whose first factorisation would be at another
  // state anyway (a map restored from a snapshot).
  enum class Factorise { kNow, kWhenRead };
  // A map at a given prior (InvalidArgument when its field does not match
  // the grid's cells or its sizes disagree; Internal if a factorisation
  // made now fails).
  [[nodiscard]] static absl::StatusOr<SparseGpMap> FromPrior(const FieldGrid& grid, GmrfPrior prior,
                                                             Factorise factorise = Factorise::kNow);

  SparseGpMap(SparseGpMap&&) noexcept;
  SparseGpMap& operator=(SparseGpMap&&) noexcept;
  SparseGpMap(const SparseGpMap&) = delete;
  SparseGpMap& operator=(const SparseGpMap&) = delete;
  ~SparseGpMap();

  // Fuses `observations`, repeated cells merged first (MergeObservations).
  // Validated before anything changes: on error the
  // map is untouched. InvalidArgument as GpMap::Update.
  [[nodiscard]] absl::Status Update(std::span<const CellObservation> observations);
  // Value 0 with variance GpMap::kNearCertainVariance at each of `cells`
  // (the ground under obstacles), repeated cells counted once.
  [[nodiscard]] absl::Status FuseNearCertainZeros(std::span<const int> cells);
  // Those observations, one per distinct cell, in cell order.
  [[nodiscard]] static std::vector<CellObservation> NearCertainZeros(std::span<const int> cells);

  // What fusing adds, for a holder that keeps only that and brings a map
  // to it when it needs one (Restore): AddedPrecision and AddedInformation.
  struct Additions {
    Eigen::VectorXd precision;
    Eigen::VectorXd information;
  };
  // Zero additions over `num_cells` cells.
  [[nodiscard]] static Additions NoAdditions(int num_cells);
  // Adds to `added` what Update(observations) adds to the map's own: a map
  // restored from `added` then equals one updated in the same order.
  // Validated first (InvalidArgument as Update); on error nothing changes.
  [[nodiscard]] static absl::Status Accumulate(std::span<const CellObservation> observations,
                                               Additions& added);

  [[nodiscard]] const FieldGrid& grid() const { return grid_; }
  [[nodiscard]] int num_cells() const { return grid_.num_cells(); }
  [[nodiscard]] const GmrfPrior& prior() const { return prior_; }
  // The posterior precision Q: the prior's plus what was fused (lower
  // triangle, the prior's pattern, over all lattice states).
  [[nodiscard]] const Eigen::SparseMatrix<double, Eigen::ColMajor, int>& precision() const {
    return precision_;
  }
  // The posterior mean over the field's cells (factorising first if
  // anything was fused since the last call). Internal if CHOLMOD fails.
  [[nodiscard]] absl::StatusOr<Eigen::VectorXd> Mean() const;
  // The posterior variance of every field cell (selected inversion of the
  // current factor; computed on the first call after an update and kept).
  [[nodiscard]] absl::StatusOr<Eigen::VectorXd> Variances() const;
  // Tr of the field's posterior covariance.
  [[nodiscard]] absl::StatusOr<double> Trace() const;

  // What the fused observations added, per field cell: sum of 1 / r and of
  // z / r. With the prior they are the whole state of the map.
  [[nodiscard]] const Eigen::VectorXd& AddedPrecision() const { return added_precision_; }
  [[nodiscard]] const Eigen::VectorXd& AddedInformation() const { return added_information_; }
  // The map at its prior with these additions (a snapshot). InvalidArgument
  // when a size does not match, an entry is not finite or a precision is
  // negative.
  [[nodiscard]] absl::Status Restore(const Eigen::VectorXd& added_precision,
                                     const Eigen::VectorXd& added_information);
  // Restore's checks of the entries alone: OK when every addition is finite
  // and every precision non-negative; InvalidArgument naming the first cell
  // that is not (the sizes are the caller's to check).
  [[nodiscard]] static absl::Status CheckAdditions(const Eigen::VectorXd& added_precision,
                                                   const Eigen::VectorXd& added_information);

  // The non-zeros of the Cholesky factor and the bytes the map holds
  // (prior, factor, the variances' workspace as large as the factor, which
  // the first variance map allocates and later ones reuse, vectors), for
  // memory estimates and benchmarks.
  [[nodiscard]] std::int64_t factor_nonzeros() const;
  [[nodiscard]] std::int64_t bytes() const;

 private:
  struct Cholmod;
  SparseGpMap(const FieldGrid& grid, GmrfPrior prior);
  // When anything was fused since the last refresh: factorises Q (the
  // symbolic analysis on the first call) and solves for the mean.
  absl::Status Refresh() const;

  FieldGrid grid_;
  GmrfPrior prior_;
  // Q (lower triangle, the prior's pattern) and b as fused so far.
  Eigen::SparseMatrix<double, Eigen::ColMajor, int> precision_;
  Eigen::VectorXd information_;
  // Where each state's diagonal entry sits in precision_'s values.
  std::vector<int> diagonal_;
  Eigen::VectorXd added_precision_;
  Eigen::VectorXd added_information_;
  mutable bool dirty_ = false;
  mutable Eigen::VectorXd mean_;
  mutable std::unique_ptr<Eigen::VectorXd> variances_;
  std::unique_ptr<Cholmod> cholmod_;
};

}  // namespace oaipp
