// Prior covariances shared between maps of the same shape (docs/method.md §3).
//
// P0 = K - K (K + sn2 I)^-1 K costs about n^3 flops (0.3 s for the paper's
// 1600 cells) but depends only on the grid's shape and the GP parameters,
// not on where the field lies or what stands on it. A fleet of missions over
// the same kind of field computes it once and copies it (n^2) per map.
//
//   PriorCache cache(/*capacity=*/4);
//   OAIPP_ASSIGN_OR_RETURN(GpMap map, cache.NewMap(grid, GpParams::PaperPreset(0.75)));
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "Eigen/Core"
#include "absl/status/statusor.h"
#include "core/common/single_flight_cache.h"
#include "core/mapping/field_grid.h"
#include "core/mapping/gp_map.h"
#include "core/mapping/gp_params.h"

namespace oaipp {

// What a prior covariance depends on: the grid's shape and resolution and
// the kernel's parameters, compared exactly (not the origin, not the prior
// mean). Also the start of the sparse priors' key (GmrfPriorCache).
struct PriorShapeKey {
  int nx = 0;
  int ny = 0;
  double resolution_m = 0.0;
  double length_scale_m = 0.0;
  double signal_var = 0.0;
  double noise_var = 0.0;
  [[nodiscard]] static PriorShapeKey Of(const FieldGrid& grid, const GpParams& params) {
    return {.nx = grid.nx(),
            .ny = grid.ny(),
            .resolution_m = grid.resolution_m(),
            .length_scale_m = params.length_scale_m,
            .signal_var = params.signal_var,
            .noise_var = params.noise_var};
  }
  bool operator==(const PriorShapeKey&) const = default;
};

// Thread-safe. Keyed by (nx, ny, resolution, length scale, signal variance,
// noise variance), compared exactly; the grid's origin and the prior mean do
// not change P0. Holds at most `capacity` priors (8 n^2 bytes each) and
// drops the least recently used one beyond that.
class PriorCache {
 public:
  // capacity >= 1 (smaller values are raised to 1).
  explicit PriorCache(int capacity = 4);

  // P0 for grid and params, equal bit for bit to PriorCovariance(grid,
  // params): computed on the first request for its key and shared after
  // that. Concurrent first requests for one key compute it once; the others
  // wait for it. Errors as PriorCovariance, and not remembered.
  [[nodiscard]] absl::StatusOr<std::shared_ptr<const Eigen::MatrixXd>> Get(const FieldGrid& grid,
                                                                           const GpParams& params);

  // A map at the prior (mean params.prior_mean), equal to
  // GpMap::Create(grid, params) but with the covariance copied from the
  // cache. Errors as GpMap::Create.
  [[nodiscard]] absl::StatusOr<GpMap> NewMap(const FieldGrid& grid, const GpParams& params);
  // The same with the prior mean `mean` per cell (grid order) instead.
  [[nodiscard]] absl::StatusOr<GpMap> NewMap(const FieldGrid& grid, const GpParams& params,
                                             Eigen::VectorXd mean);

  // How many priors were computed (cache misses), and how many are held.
  [[nodiscard]] std::int64_t computations() const;
  [[nodiscard]] int size() const;

 private:
  SingleFlightCache<PriorShapeKey, Eigen::MatrixXd> priors_;
};

}  // namespace oaipp
