#include "core/mapping/prior_cache.h"

#include "core/common/status_macros.h"

namespace oaipp {

PriorCache::PriorCache(int capacity) : priors_(capacity) {}

absl::StatusOr<std::shared_ptr<const Eigen::MatrixXd>> PriorCache::Get(const FieldGrid& grid,
                                                                       const GpParams& params) {
  return priors_.Get(PriorShapeKey::Of(grid, params),
                     [&] { return PriorCovariance(grid, params); });
}

absl::StatusOr<GpMap> PriorCache::NewMap(const FieldGrid& grid, const GpParams& params) {
  return NewMap(grid, params, Eigen::VectorXd::Constant(grid.num_cells(), params.prior_mean));
}

absl::StatusOr<GpMap> PriorCache::NewMap(const FieldGrid& grid, const GpParams& params,
                                         Eigen::VectorXd mean) {
  OAIPP_RETURN_IF_ERROR(params.Validate());
  OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<const Eigen::MatrixXd> p0, Get(grid, params));
  return GpMap::FromPrior(grid, std::move(mean), *p0);
}

std::int64_t PriorCache::computations() const { return priors_.computations(); }

int PriorCache::size() const { return priors_.size(); }

}  // namespace oaipp
