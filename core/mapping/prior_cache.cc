#include "core/mapping/prior_cache.h"

#include "core/common/status_macros.h"

namespace oaipp {

PriorCache::PriorCache(int capacity) : priors_(capacity) {}

absl::StatusOr<std::shared_ptr<const Eigen::MatrixXd>> PriorCache::Get(const FieldGrid& grid,
                                                                       const GpParams& params) {
  const Key key{.nx = grid.nx(),
                .ny = grid.ny(),
                .resolution_m = grid.resolution_m(),
                .length_scale_m = params.length_scale_m,
                .signal_var = params.signal_var,
                .noise_var = params.noise_var};
  return priors_.Get(key, [&] { return PriorCovariance(grid, params); });
}

absl::StatusOr<GpMap> PriorCache::NewMap(const FieldGrid& grid, const GpParams& params) {
  OAIPP_RETURN_IF_ERROR(params.Validate());
  OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<const Eigen::MatrixXd> p0, Get(grid, params));
  return GpMap::FromPrior(grid, Eigen::VectorXd::Constant(grid.num_cells(), params.prior_mean),
                          *p0);
}

std::int64_t PriorCache::computations() const { return priors_.computations(); }

int PriorCache::size() const { return priors_.size(); }

}  // namespace oaipp
