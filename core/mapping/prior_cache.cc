#include "core/mapping/prior_cache.h"

#include <algorithm>
#include <utility>

#include "core/common/status_macros.h"

namespace oaipp {

PriorCache::PriorCache(int capacity) : capacity_(std::max(capacity, 1)) {}

absl::StatusOr<std::shared_ptr<const Eigen::MatrixXd>> PriorCache::Get(const FieldGrid& grid,
                                                                       const GpParams& params) {
  const Key key{.nx = grid.nx(),
                .ny = grid.ny(),
                .resolution_m = grid.resolution_m(),
                .length_scale_m = params.length_scale_m,
                .signal_var = params.signal_var,
                .noise_var = params.noise_var};
  std::shared_future<Result> prior;
  std::promise<Result> promise;
  bool compute = false;
  std::uint64_t inserted = 0;
  {
    absl::MutexLock lock(&mu_);
    auto it = std::find_if(entries_.begin(), entries_.end(),
                           [&](const Entry& e) { return e.key == key; });
    if (it != entries_.end()) {
      it->last_used = ++clock_;
      prior = it->prior;
    } else {
      if (static_cast<int>(entries_.size()) >= capacity_) {
        // Waiters on an evicted prior hold their own copy of its future.
        entries_.erase(std::min_element(
            entries_.begin(), entries_.end(),
            [](const Entry& a, const Entry& b) { return a.last_used < b.last_used; }));
      }
      prior = promise.get_future().share();
      inserted = ++clock_;
      entries_.push_back({key, prior, inserted, inserted});
      ++computations_;
      compute = true;
    }
  }
  if (compute) {
    absl::StatusOr<Eigen::MatrixXd> p0 = PriorCovariance(grid, params);
    if (p0.ok()) {
      promise.set_value(std::make_shared<const Eigen::MatrixXd>(std::move(p0).value()));
    } else {
      promise.set_value(p0.status());
      absl::MutexLock lock(&mu_);
      std::erase_if(entries_, [&](const Entry& e) { return e.inserted == inserted; });
    }
  }
  return prior.get();
}

absl::StatusOr<GpMap> PriorCache::NewMap(const FieldGrid& grid, const GpParams& params) {
  OAIPP_RETURN_IF_ERROR(params.Validate());
  OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<const Eigen::MatrixXd> p0, Get(grid, params));
  return GpMap::FromPrior(grid, Eigen::VectorXd::Constant(grid.num_cells(), params.prior_mean),
                          *p0);
}

std::int64_t PriorCache::computations() const {
  absl::MutexLock lock(&mu_);
  return computations_;
}

int PriorCache::size() const {
  absl::MutexLock lock(&mu_);
  return static_cast<int>(entries_.size());
}

}  // namespace oaipp
