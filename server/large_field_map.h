// A large-field mission's map (FieldSpec.map_backend SPARSE; docs/method.md
// §3.9), read off the mission's lock.
//
// The mission keeps only what its measurements added to the prior
// (SparseGpMap::Additions, 16 bytes a cell) and a version that counts its
// fusions: a fusion under the mission's lock then costs O(cells seen), and
// recovery, snapshots and every copy agree bit for bit, because every map
// read is built from those additions the same way (SparseGpMap::Restore).
// This holds the one SparseGpMap and brings it to a mission's additions
// when a reader asks: a refactorisation (0.44 s at 90,000 cells), then the
// variances for a reading (0.4 s more) or a dense window for a plan. Its
// callers (a plan, GetMap, the background refresh after a measurement) take
// turns on its own lock and never hold the mission's.
//
//   OAIPP_ASSIGN_OR_RETURN(auto map, LargeFieldMap::Create(grid, config.gp));
//   OAIPP_ASSIGN_OR_RETURN(auto reading, map->Read(target));   // mean, variances, trace
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>

#include "Eigen/Core"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "core/common/geometry.h"
#include "core/mapping/field_grid.h"
#include "core/mapping/gp_map.h"
#include "core/mapping/gp_params.h"
#include "core/mapping/sparse_gp_map.h"
#include "core/planning/large_field.h"

namespace oaipp::server {

class LargeFieldMap {
 public:
  // The map at its prior (MakeGmrfPrior, about 1 s at 90,000 cells; with
  // `priors`, the site's, copied); its factorisation waits for the first
  // Read or Window. With `prior_mean` (one value per cell), the prior's
  // mean is that map instead of params.prior_mean (SetPriorMean). Errors as
  // MakeGmrfPrior and SetPriorMean.
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<LargeFieldMap>> Create(
      const FieldGrid& grid, const GpParams& params, GmrfPriorCache* priors = nullptr,
      const Eigen::VectorXd* prior_mean = nullptr);

  // A mission's map as of one fusion: the additions and their version
  // (versions grow with every fusion, so a later one is a newer map).
  struct Target {
    std::shared_ptr<const SparseGpMap::Additions> added;
    std::int64_t version = 0;
    std::int64_t measurements_fused = 0;
  };
  // Everything a reader of the whole map needs.
  struct Reading {
    std::int64_t version = 0;
    std::int64_t measurements_fused = 0;
    Eigen::VectorXd mean;
    Eigen::VectorXd variances;
    double trace = 0.0;
  };

  // The reading at `target`: the last one when it is current, else
  // computed. Errors: InvalidArgument for additions that do not fit the
  // field, Internal when CHOLMOD fails.
  [[nodiscard]] absl::StatusOr<std::shared_ptr<const Reading>> Read(const Target& target);
  // The dense map of `window` (PlanningWindow) at `target`, for a plan
  // (core/planning/large_field.h). Errors as Read and WindowMap.
  [[nodiscard]] absl::StatusOr<GpMap> Window(const Target& target, const FieldWindow& window,
                                             const LargeFieldPlanning& options);
  // The newest reading computed so far; nullptr until the first Read.
  [[nodiscard]] std::shared_ptr<const Reading> latest() const;
  // Bytes the map holds at its peak (SparseGpMap::bytes, with the factor).
  [[nodiscard]] std::int64_t bytes() const { return bytes_.load(); }
  [[nodiscard]] const FieldGrid& grid() const { return grid_; }
  // The prior's variance at a cell (its fitted interior value), for
  // WindowCentre.
  [[nodiscard]] double prior_variance() const { return prior_variance_; }

 private:
  LargeFieldMap(FieldGrid grid, SparseGpMap map);
  // Brings map_ to `target` (a Restore when its version differs).
  absl::Status BringTo(const Target& target) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const FieldGrid grid_;
  const double prior_variance_;
  absl::Mutex mu_;
  SparseGpMap map_ ABSL_GUARDED_BY(mu_);
  std::int64_t version_ ABSL_GUARDED_BY(mu_) = 0;
  std::atomic<std::int64_t> bytes_{0};
  mutable absl::Mutex latest_mu_;
  std::shared_ptr<const Reading> latest_ ABSL_GUARDED_BY(latest_mu_);
};

}  // namespace oaipp::server
