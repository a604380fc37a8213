// A covariance conditioned on a set of poses that changes a little from one
// use to the next, kept between uses.
//
// A team mission's plans each condition the map on every teammate's pending
// shots and the planning UAV's own first shot (docs/teams.md). Two plans in
// a row differ in two UAVs' shots only: the one that planned last has new
// ones, the one planning now is left out. Conditioning afresh costs about
// k^2 n + k n^2 for the k cells of every pending shot, most of the field in
// a team of 8; the chain instead takes the poses no longer in the set back
// out (RemovePoses, exact in the information form) and fuses the new ones
// (FusePoses), at the same cost for the few cells that changed.
//
//   ConditioningChain chain;
//   OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<const Eigen::MatrixXd> p_c,
//                          chain.Condition(map.Covariance(), key, prefix, backend));
//
// The result equals FusePoses(prefix) on a copy of the covariance to
// rounding, not bit for bit: it depends on the order of the calls before
// it, which is deterministic when they are. Thread-safe; the calls are
// serialised.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "Eigen/Core"
#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "core/mapping/dense_backend.h"
#include "core/planning/information.h"

namespace oaipp {

class ConditioningChain {
 public:
  // At most this many incremental steps follow a fresh conditioning, and
  // no removal may amplify rounding by more than kMaxAmplification: their
  // errors add up to at most about 32 x 1e4 x 1e-16 of the covariance's
  // scale (tests/core/planning/conditioning_chain_test.cc measures them).
  static constexpr int kMaxSteps = 32;
  static constexpr double kMaxAmplification = 1e4;

  struct Stats {
    std::int64_t fresh = 0;        // conditionings from the covariance itself
    std::int64_t incremental = 0;  // from the last result
    std::int64_t reused = 0;       // the last result as it was
  };

  // `cov` (n x n, symmetric) conditioned on `poses`. `source` names `cov`:
  // the caller promises that a call with the source of the last call passes
  // the same covariance, unchanged. A new source (another map version or
  // another window) starts afresh. The result
  // stays valid, unchanged, for as long as it is held; the chain copies it
  // before changing it while it is.
  [[nodiscard]] absl::StatusOr<std::shared_ptr<const Eigen::MatrixXd>> Condition(
      const Eigen::MatrixXd& cov, const CovarianceKey& source,
      std::span<const PoseObservation> poses, const DenseBackend& backend);

  [[nodiscard]] Stats stats() const;
  // What the kept result holds in memory (8 n^2 bytes, or 0).
  [[nodiscard]] std::int64_t bytes() const;

 private:
  mutable absl::Mutex mu_;
  std::optional<CovarianceKey> source_ ABSL_GUARDED_BY(mu_);
  std::vector<PoseObservation> poses_ ABSL_GUARDED_BY(mu_);  // what result_ is conditioned on
  std::shared_ptr<Eigen::MatrixXd> result_ ABSL_GUARDED_BY(mu_);
  int steps_ ABSL_GUARDED_BY(mu_) = 0;  // incremental steps since the last fresh one
  Stats stats_ ABSL_GUARDED_BY(mu_);
};

}  // namespace oaipp
