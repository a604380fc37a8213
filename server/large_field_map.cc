#include "server/large_field_map.h"

#include <algorithm>
#include <utility>

#include "core/common/status_macros.h"
#include "core/mapping/field_window.h"

namespace oaipp::server {

absl::StatusOr<std::unique_ptr<LargeFieldMap>> LargeFieldMap::Create(
    const FieldGrid& grid, const GpParams& params, GmrfPriorCache* priors,
    const Eigen::VectorXd* prior_mean) {
  GmrfPrior prior;
  if (priors != nullptr) {
    OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<const GmrfPrior> shared, priors->Get(grid, params));
    prior = *shared;
  } else {
    OAIPP_ASSIGN_OR_RETURN(prior, MakeGmrfPrior(grid, params));
  }
  if (prior_mean != nullptr) OAIPP_RETURN_IF_ERROR(SetPriorMean(prior, grid, *prior_mean));
  // Its first factorisation is the first read's, at the mission's own
  // state (a factorisation at the prior would be thrown away): a restored
  // mission's additions keep Q positive definite (checked non-negative), and
  // a new one reads its map before it is shared.
  OAIPP_ASSIGN_OR_RETURN(
      SparseGpMap map,
      SparseGpMap::FromPrior(grid, std::move(prior), SparseGpMap::Factorise::kWhenRead));
  // No reading yet: the mission's first Read, at its own state, is the
  // one that counts (a reading of the prior here would cost a variance map,
  // 0.8 s at 90,000 cells, that nobody reads).
  return std::unique_ptr<LargeFieldMap>(new LargeFieldMap(grid, std::move(map)));
}

LargeFieldMap::LargeFieldMap(FieldGrid grid, SparseGpMap map)
    : grid_(std::move(grid)),
      prior_variance_(map.prior().fit.fitted_p0_variance),
      map_(std::move(map)) {}

absl::Status LargeFieldMap::BringTo(const Target& target) {
  if (target.version == version_) return absl::OkStatus();
  if (target.added == nullptr) {
    OAIPP_RETURN_IF_ERROR(map_.Restore(Eigen::VectorXd::Zero(grid_.num_cells()),
                                       Eigen::VectorXd::Zero(grid_.num_cells())));
  } else {
    OAIPP_RETURN_IF_ERROR(map_.Restore(target.added->precision, target.added->information));
  }
  version_ = target.version;
  return absl::OkStatus();
}

absl::StatusOr<std::shared_ptr<const LargeFieldMap::Reading>> LargeFieldMap::Read(
    const Target& target) {
  if (std::shared_ptr<const Reading> last = latest();
      last != nullptr && last->version == target.version) {
    return last;
  }
  absl::MutexLock lock(&mu_);
  // Another reader may have computed it while this one waited.
  if (std::shared_ptr<const Reading> last = latest();
      last != nullptr && last->version == target.version) {
    return last;
  }
  OAIPP_RETURN_IF_ERROR(BringTo(target));
  auto reading = std::make_shared<Reading>();
  reading->version = target.version;
  reading->measurements_fused = target.measurements_fused;
  OAIPP_ASSIGN_OR_RETURN(reading->mean, map_.Mean());
  OAIPP_ASSIGN_OR_RETURN(reading->variances, map_.Variances());
  reading->trace = reading->variances.sum();
  // The factor and, once a variance map was computed, Z in its layout.
  bytes_.store(std::max(bytes_.load(), map_.bytes()));
  absl::MutexLock latest_lock(&latest_mu_);
  // Readers may finish out of order: the newest stays.
  if (latest_ == nullptr || latest_->version < reading->version) latest_ = reading;
  return std::shared_ptr<const Reading>(std::move(reading));
}

absl::StatusOr<GpMap> LargeFieldMap::Window(const Target& target, const FieldWindow& window,
                                            const LargeFieldPlanning& options) {
  absl::MutexLock lock(&mu_);
  OAIPP_RETURN_IF_ERROR(BringTo(target));
  return WindowMap(map_, window, options.window, options.backend);
}

std::shared_ptr<const LargeFieldMap::Reading> LargeFieldMap::latest() const {
  absl::MutexLock lock(&latest_mu_);
  return latest_;
}

}  // namespace oaipp::server
