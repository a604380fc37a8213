#include "core/planning/conditioning_chain.h"

#include <algorithm>
#include <numeric>
#include <utility>

namespace oaipp {
namespace {

// A pose as conditioning sees it: its cells and noise variance (altitude and
// scoring do not enter).
bool Less(const PoseObservation& a, const PoseObservation& b) {
  if (a.variance != b.variance) return a.variance < b.variance;
  return a.cells < b.cells;
}
bool Same(const PoseObservation& a, const PoseObservation& b) {
  return a.variance == b.variance && a.cells == b.cells;
}

std::vector<std::size_t> SortedOrder(std::span<const PoseObservation> poses) {
  std::vector<std::size_t> order(poses.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return Less(poses[a], poses[b]); });
  return order;
}

// The poses of `from` not in `to` and those of `to` not in `from`, as
// multisets, each in its own order.
void Difference(std::span<const PoseObservation> from, std::span<const PoseObservation> to,
                std::vector<PoseObservation>* removed, std::vector<PoseObservation>* added) {
  const std::vector<std::size_t> a = SortedOrder(from);
  const std::vector<std::size_t> b = SortedOrder(to);
  std::vector<char> in_a(from.size(), 0), in_b(to.size(), 0);
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (Same(from[a[i]], to[b[j]])) {
      in_a[a[i++]] = in_b[b[j++]] = 1;
    } else if (Less(from[a[i]], to[b[j]])) {
      ++i;
    } else {
      ++j;
    }
  }
  for (std::size_t k = 0; k < from.size(); ++k) {
    if (in_a[k] == 0) removed->push_back(from[k]);
  }
  for (std::size_t k = 0; k < to.size(); ++k) {
    if (in_b[k] == 0) added->push_back(to[k]);
  }
}

// Multiply-adds of conditioning an n x n covariance on k cells: the
// whitening (k^2 n / 2), the rank-k update (k n^2 / 2), the factor (k^3 / 6).
double Cost(std::int64_t k, Eigen::Index n) {
  const auto kd = static_cast<double>(k);
  const auto nd = static_cast<double>(n);
  return 0.5 * kd * kd * nd + 0.5 * kd * nd * nd + kd * kd * kd / 6.0;
}

}  // namespace

absl::StatusOr<std::shared_ptr<const Eigen::MatrixXd>> ConditioningChain::Condition(
    const Eigen::MatrixXd& cov, const CovarianceKey& source, std::span<const PoseObservation> poses,
    const DenseBackend& backend) {
  absl::MutexLock lock(&mu_);
  if (result_ != nullptr && source_ == source && steps_ < kMaxSteps &&
      result_->rows() == cov.rows()) {
    std::vector<PoseObservation> removed, added;
    Difference(poses_, poses, &removed, &added);
    if (removed.empty() && added.empty()) {
      ++stats_.reused;
      return std::shared_ptr<const Eigen::MatrixXd>(result_);
    }
    const double incremental =
        Cost(DistinctCells(removed), cov.rows()) + Cost(DistinctCells(added), cov.rows());
    if (incremental < Cost(DistinctCells(poses), cov.rows())) {
      // A result still held by a plan is left as it is.
      if (result_.use_count() > 1) result_ = std::make_shared<Eigen::MatrixXd>(*result_);
      if (RemovePoses(backend, removed, kMaxAmplification, *result_).ok()) {
        FusePoses(backend, added, *result_);
        poses_.assign(poses.begin(), poses.end());
        ++steps_;
        ++stats_.incremental;
        return std::shared_ptr<const Eigen::MatrixXd>(result_);
      }
      // Not removable to the accuracy kept: afresh (RemovePoses left
      // result_ as it was, and it is replaced below).
    }
  }
  auto fresh = std::make_shared<Eigen::MatrixXd>(cov);
  FusePoses(backend, poses, *fresh);
  result_ = std::move(fresh);
  source_ = source;
  poses_.assign(poses.begin(), poses.end());
  steps_ = 0;
  ++stats_.fresh;
  return std::shared_ptr<const Eigen::MatrixXd>(result_);
}

ConditioningChain::Stats ConditioningChain::stats() const {
  absl::MutexLock lock(&mu_);
  return stats_;
}

std::int64_t ConditioningChain::bytes() const {
  absl::MutexLock lock(&mu_);
  return result_ == nullptr ? 0 : 8 * result_->size();
}

}  // namespace oaipp
