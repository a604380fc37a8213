// The information objectives O_info of docs/method.md §6, evaluated fast.
//
// A candidate path is reduced to its measurement poses, each a set of
// visible ground cells observed with one noise variance. Two objectives:
//  - adaptive (the paper's Eq. 9): for each pose i below h_sat,
//      AV_i = sum over its cells x of mu(x) + kappa * sigma_i(x),
//    where sigma_i is the predicted standard deviation after fusing poses
//    1 .. i-1, weighted by the altitude reward N(h_i; h_opt, sigma1);
//  - non-adaptive (Eq. 8): Tr(P) before minus Tr(P) after fusing every pose.
// The adaptive form takes an optional confirmation term (docs/method.md,
// "Confirmation"): with weight lambda > 0 each cell of pose i also earns
//   lambda * (M_before(x) - E[M_after(x)]),
// the expected reduction of the probability that the map misclassifies x
// against the decision threshold theta, for a Gaussian belief N(mu, sigma_i^2)
// observed once with the pose's noise variance r:
//   M_before = Phi(-|theta - mu| / sigma_i),
//   E[M_after] = 2 T((theta - mu) / sigma_i, sqrt(r) / sigma_i)
// (T: Owen's T function; the probability that the true value and the
// posterior mean lie on different sides of theta). It is largest on cells
// whose mean sits near theta (a person seen once and missed once) and
// shrinks with r, so low, accurate shots earn more of it.
//
// Neither needs the n x n covariance to be copied or updated. Fusing
// observations of the cells K with noise R changes the covariance by
// -P_:K (P_KK + R)^-1 P_K: (information form: repeated cells merge by adding
// precisions), so with L the Cholesky factor of P_KK + R
//   sigma_i^2(x) = P_xx - |L^-1 P_K,x|^2            (only cells x of pose i)
//   Tr reduction = |L^-1 P_K,:|_F^2 = sum((P_KK + R)^-1 o (P^2)_KK)
// The trace form costs m^2 n per candidate (m observed cells); with P^2
// computed once per evaluator (a symmetric product, n^3 flops) it costs
// about m^3, which
// pays when many candidates are scored against one map.
// The plain reference (full Kalman updates on a copy, as the published code
// does) is kept beside it as the test oracle.
//
//   InformationEvaluator info(map.Mean(), map.Covariance(), params);
//   double o = info.Evaluate(poses);          // fast
//   double r = ReferenceInformation(map.Mean(), map.Covariance(), params, poses);
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "Eigen/Core"
#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "core/common/single_flight_cache.h"
#include "core/mapping/dense_backend.h"

namespace oaipp {

// kDetection: the probability of finding a person (docs/method.md §6.6):
// for each scored pose i, in order,
//   D_i = gamma^i * p_i * sum over its cells x of m(x) * prod over earlier
//         poses j that see x of (1 - p_j),
// with m(x) = mu(x) clamped to [0, 1] (the probability, as the map holds it
// now, that x holds the person: a probability prior map's value before any
// shot), p_i the detector's probability of seeing a person in view from
// pose i (PoseObservation::detection_probability) and gamma the discount
// per shot (InformationParams::detection_discount): a search values finding
// someone sooner. It reads the mean only: no covariance, no solve.
enum class ObjectiveKind { kAdaptive, kNonAdaptive, kDetection };

struct InformationParams {
  ObjectiveKind kind = ObjectiveKind::kAdaptive;
  // UCB exploration weight kappa (Eq. 7). Valid: >= 0.
  double kappa = 1.0;
  // Detector reward N(h; h_opt, sigma1) (Eq. 9), metres. Valid: sigma1 > 0.
  double h_opt_m = 10.0;
  double sigma1_m = 7.0;
  // Poses at or above h_sat earn nothing (Eq. 9), metres.
  double h_sat_m = 26.0;
  // Weight lambda of the confirmation term (adaptive objective only). 0 (the
  // default) is the paper's objective, unchanged. Valid: >= 0, finite.
  double confirmation_weight = 0.0;
  // How the confirmation term reads a cell that earlier shots of the plan
  // (the path's own, and teammates' pending ones) will see too. False (the
  // default): as if the belief now were N(mu, predicted variance), the mean
  // unmoved by those shots, which values a second look too much on the
  // threshold and too little away from it. True:
  // from the map's belief now, N(mu, variance now), over what those shots
  // may show (docs/method.md "Confirmation"); for a cell no earlier shot
  // sees, the two are equal to rounding.
  bool confirmation_preposterior = false;
  // theta: a cell counts as a target where its mean exceeds it. Valid: in
  // (0, 1).
  double decision_threshold = 0.5;
  // Confirmation phase (adaptive objective only): plans asked for with at
  // most this much flight budget left (seconds) stop exploring and go back
  // to what is undecided. 0 (the default): no phase. Valid: >= 0, finite.
  double confirmation_phase_s = 0.0;
  // In the phase, kappa is 0 and a cell whose mean lies within
  // ambiguity_margin of theta earns confirmation_phase_weight times its
  // predicted variance. Valid: weight >= 0 and finite; margin in (0, 0.5].
  double confirmation_phase_weight = 3000.0;
  double ambiguity_margin = 0.25;
  // In the phase, each other cell earns second_look_weight times its
  // predicted variance: a second look at ground seen once, where a person
  // may have been missed. 0 (the default): none. Valid: >= 0, finite.
  double second_look_weight = 0.0;
  // With second_look_sharpness alpha > 0 such a cell earns second_look_weight
  // times exp(-alpha / variance) instead: each look adds to 1/variance, so
  // this falls by a large factor per look (most at the first), as the
  // chance that a person there was missed every time does; the variance
  // itself falls only about 1.5x. 0 (the default): the variance itself.
  // Valid: >= 0, finite.
  double second_look_sharpness = 0.0;
  // The detection objective's discount per scored shot, gamma in (0, 1]: 1
  // (the default) values a find late in the path as one now.
  double detection_discount = 1.0;
  // True when these are the phase's parameters (set by ForRemainingBudget).
  bool confirming = false;
  // Off by default: the adaptive objective's solves (the Cholesky factor
  // of the fused cells, the triangular solve of a shot's new cells against
  // it, the inverse of its seen cells' block) and those of
  // PosteriorVariances (the greedy start's) run in single precision, on the
  // covariance's values rounded to floats; the map, its updates and every
  // other computation stay double. OpenBLAS's single-precision kernels take
  // about half the time. Against the double-precision oracle, scores agree
  // to about 3e-8 relative and PosteriorVariances to about 3e-7 of the
  // prior's variance (information_test.cc), so a search may rank two
  // candidates the other way and take another step; as reproducible, but
  // not bit for bit double's. A factor that fails in single precision is
  // taken in double. docs/capacity.md measures what it saves and costs. A
  // setting of the server (--objective_precision), not of the mission spec.
  bool single_precision = false;
  // Where the objective's dense products run (core/mapping/dense_backend.h):
  // Eigen unless set. A setting of the server (--dense_backend), not of the
  // mission spec.
  DenseBackend dense_backend = {};

  // InvalidArgument naming the first bad field.
  [[nodiscard]] absl::Status Validate() const;
  // N(h; h_opt, sigma1), or 0 at and above h_sat.
  [[nodiscard]] double AltitudeReward(double altitude_m) const;
  // The parameters a plan asked for with `remaining_budget_s` of flight
  // left scores with: these, or inside the confirmation phase a copy with
  // confirming set and kappa 0.
  [[nodiscard]] InformationParams ForRemainingBudget(double remaining_budget_s) const;
  // What one cell with map mean `mean` and predicted variance `variance`
  // earns in a pose observed with noise variance `noise_variance` (before
  // the altitude reward): mu + kappa sigma, plus the confirmation term when
  // its weight is positive, plus in the confirmation phase the ambiguity
  // term, or the second-look term for a cell outside the margin.
  // `prior_variance` is the cell's variance in the map now, before any shot
  // of the plan; read only with confirmation_preposterior (negative: take
  // `variance`).
  [[nodiscard]] double CellValue(double mean, double variance, double noise_variance,
                                 double prior_variance = -1.0) const;
  // The second-look term of a cell with predicted variance `variance`,
  // unweighted: the variance, or exp(-second_look_sharpness / variance); 0
  // for a variance that is not positive.
  [[nodiscard]] double SecondLook(double variance) const;
};

// Expected reduction of the misclassification probability of a cell with
// belief N(mean, variance) against `threshold` from one observation with
// noise variance `noise_variance` >= 0 (the confirmation term above,
// unweighted; a noiseless observation removes all of M_before). 0 for a
// cell whose variance is not positive: it has nothing left to learn.
[[nodiscard]] double MisclassificationReduction(double mean, double variance, double noise_variance,
                                                double threshold);
// The same for a cell whose belief now is N(mean, prior_variance) and which
// earlier observations will have left with `variance` <= prior_variance when
// this one comes: the expected misclassification probability after those
// observations less that after this one too, both over what the
// observations may show, seen from now. Equal to MisclassificationReduction
// to rounding when variance == prior_variance; 0 when variance is not
// positive.
[[nodiscard]] double PreposteriorMisclassificationReduction(double mean, double prior_variance,
                                                            double variance, double noise_variance,
                                                            double threshold);

inline double InformationParams::SecondLook(double variance) const {
  if (!(variance > 0.0)) return 0.0;
  return second_look_sharpness > 0.0 ? std::exp(-second_look_sharpness / variance) : variance;
}

inline double InformationParams::CellValue(double mean, double variance, double noise_variance,
                                           double prior_variance) const {
  double value = mean + kappa * std::sqrt(std::max(variance, 0.0));
  if (confirmation_weight > 0.0) {
    value += confirmation_weight *
             (confirmation_preposterior
                  ? PreposteriorMisclassificationReduction(
                        mean, prior_variance < 0.0 ? variance : prior_variance, variance,
                        noise_variance, decision_threshold)
                  : MisclassificationReduction(mean, variance, noise_variance, decision_threshold));
  }
  if (confirming && std::abs(mean - decision_threshold) < ambiguity_margin) {
    value += confirmation_phase_weight * std::max(variance, 0.0);
  } else if (confirming && second_look_weight > 0.0) {
    value += second_look_weight * SecondLook(variance);
  }
  return value;
}

// One measurement: the visible ground cells it observes (distinct indices),
// the observation noise variance var(h) and the camera altitude.
struct PoseObservation {
  std::vector<int> cells;
  double variance = 1.0;
  double altitude_m = 10.0;
  // Probability that the detector sees a person in one of the cells from
  // here (the detection objective's p_i), in [0, 1].
  double detection_probability = 1.0;
  // When false the pose is fused (it conditions later poses) but earns
  // nothing itself: used for a shot the candidate cannot influence (taken
  // where the UAV already is). Unscored poses come before scored ones.
  bool scored = true;
};

// What a covariance conditioned on a prefix depends on besides the
// covariance: each prefix pose's cells and noise variance.
struct PrefixKey {
  std::vector<std::vector<int>> cells;
  std::vector<double> variances;
  bool operator==(const PrefixKey&) const = default;
};
// Covariances conditioned on a prefix (InformationEvaluator::Condition),
// shared by the evaluators of many plans over one covariance that does not
// change while the cache is used with it: the missions of a fleet that start
// from one shared map at one start point all condition it on the same first
// shot, and compute it once (a copy and a rank-k update of n^2 doubles).
using ConditionedCache = SingleFlightCache<PrefixKey, Eigen::MatrixXd>;

// P := P - P_:K (P_KK + R)^-1 P_K: in place: `poses` fused into the
// covariance (their cells K merged, R their merged noise), about
// k^2 n + k n^2 flops.
void FusePoses(const DenseBackend& backend, std::span<const PoseObservation> poses,
               Eigen::MatrixXd& cov);
// The inverse of FusePoses for poses `cov` holds (fused into it before, in
// any order among others): P := P + P_:K (R - P_KK)^-1 P_K:, exact in the
// information form (P^-1 -= H^T R^-1 H). FailedPrecondition, `cov`
// unchanged, when R - P_KK is not positive definite or some r_j /
// (R - P_KK)_jj exceeds `max_amplification`: about log10 of it digits are
// lost in the subtraction (docs/teams.md).
absl::Status RemovePoses(const DenseBackend& backend, std::span<const PoseObservation> poses,
                         double max_amplification, Eigen::MatrixXd& cov);
// How many distinct cells `poses` observe.
[[nodiscard]] std::int64_t DistinctCells(std::span<const PoseObservation> poses);

class ConditioningChain;
// Which covariance a ConditioningChain is handed, as its caller names it:
// the version of the map it was read from and the block of the field's
// cells it covers (a large field's planning window, or the whole field):
// first row and column, rows and columns. Equal keys promise equal
// covariances; a window read elsewhere or at another version differs.
struct CovarianceKey {
  std::int64_t map_version = 0;
  int first_row = 0;
  int first_col = 0;
  int rows = 0;
  int cols = 0;
  bool operator==(const CovarianceKey&) const = default;
};
// A chain that makes a prefix's conditioned covariance from the one it made
// last (conditioning_chain.h), with the caller's key for the covariance.
struct ChainedPrefix {
  ConditioningChain* chain = nullptr;
  CovarianceKey source;
};

class InformationEvaluator {
 public:
  // Holds references: mean (n) and covariance (n x n, symmetric) must
  // outlive the evaluator and stay unchanged while it is used. Not safe for
  // concurrent use (it caches P^2).
  // `area` (empty, or one byte per cell, as `area` must outlive the
  // evaluator too): the cells worth searching, nonzero inside a mission's
  // search area. A cell outside earns nothing: the adaptive and detection
  // objectives sum over the inside cells a pose sees, the non-adaptive one
  // takes the trace over the inside cells; every pose is still fused whole,
  // so a shot outside lowers the variance of inside cells it is correlated
  // with. Empty: every cell counts. Precondition: empty or n bytes.
  InformationEvaluator(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance,
                       const InformationParams& params, std::span<const std::uint8_t> area = {})
      : mean_(mean), cov_(covariance), params_(params), area_(area) {}

  // Fuses `prefix` (unscored poses, e.g. the shot due where the UAV is now,
  // which every candidate of a replan shares) into a private copy of the
  // covariance, once: P_c = P - P_:K (P_KK + R)^-1 P_K:. Later Evaluate and
  // PosteriorVariances calls whose poses begin with exactly these poses start
  // from P_c and skip them; others take the plain path. About k n^2 flops
  // for k prefix cells, n^2 doubles of memory. InvalidArgument if a prefix
  // pose is scored.
  // With `shared`, P_c comes from it (made there on first need), as computed
  // here bit for bit: the caller promises that `shared` serves this
  // evaluator's covariance only. With `chain.chain` (then `shared` is not
  // read), P_c comes from the chain, equal to the one computed here to
  // rounding (docs/teams.md).
  absl::Status Condition(std::vector<PoseObservation> prefix, ConditionedCache* shared = nullptr,
                         ChainedPrefix chain = {});

  [[nodiscard]] ObjectiveKind kind() const { return params_.kind; }

  // Evaluate calls since Condition whose poses did not begin with the
  // prefix bit for bit: each fused the prefix again on the unconditioned
  // covariance. The value is the same; the cost is k n^2 more. A planner's
  // candidates all begin with its prefix, so for them this stays 0.
  [[nodiscard]] std::int64_t prefix_misses() const { return prefix_misses_; }

  // O_info of fusing `poses` in order. Preconditions: valid cell indices,
  // positive variances (the planner builds them; not re-checked here).
  [[nodiscard]] double Evaluate(std::span<const PoseObservation> poses) const;

  // Predicted variance of every cell after fusing all of `poses` (n values).
  // With it, a single further pose is valued in O(cells) by PoseValue: the
  // greedy start scores many one-shot candidates against one history so.
  [[nodiscard]] Eigen::VectorXd PosteriorVariances(std::span<const PoseObservation> poses) const;
  // The adaptive value of one scored `pose` whose cells have the predicted
  // `variances`: N(h) * sum over cells of mu + kappa sigma. Equals
  // Evaluate(history + {pose}) with variances = PosteriorVariances(history).
  [[nodiscard]] double PoseValue(const PoseObservation& pose,
                                 const Eigen::VectorXd& variances) const;

 private:
  // Number of leading poses covered by the conditioned prefix: prefix_.size()
  // when `poses` begins with it, else 0.
  [[nodiscard]] std::size_t PrefixLength(std::span<const PoseObservation> poses) const;
  [[nodiscard]] double Adaptive(std::span<const PoseObservation> poses,
                                const Eigen::MatrixXd& base) const;
  template <typename Scalar>
  [[nodiscard]] double AdaptiveIn(std::span<const PoseObservation> poses,
                                  const Eigen::MatrixXd& base) const;
  [[nodiscard]] double NonAdaptive(std::span<const PoseObservation> poses,
                                   const Eigen::MatrixXd& base, bool base_is_cached) const;
  // The detection objective of `poses`, from the mean alone (all of them:
  // a conditioned prefix changes the covariance only).
  [[nodiscard]] double Detection(std::span<const PoseObservation> poses) const;

  // (B^2) of the base the non-adaptive objective starts from (P_c when a
  // prefix is conditioned, else P), computed on first need.
  const Eigen::MatrixXd& BaseSquared() const;
  // Whether a reduction over m cells should read B^2. Building it costs
  // about n^3 / 2 multiply-adds, each evaluation without it about m^2 n:
  // B^2 is built only once the evaluations without it have cost as much
  // (so the total is within 2x of the better choice in hindsight, and the
  // first evaluations of a plan, which an anytime answer waits for, stay
  // cheap).
  [[nodiscard]] bool UseBaseSquared(Eigen::Index m, Eigen::Index n) const;
  // Cell c's variance in the map now, which only the preposterior
  // confirmation term reads (-1 otherwise: a strided read into P that the
  // per-cell loops skip).
  [[nodiscard]] double PriorVariance(int c) const {
    return params_.confirmation_preposterior ? cov_(c, c) : -1.0;
  }
  [[nodiscard]] bool InArea(int c) const {
    return area_.empty() || area_[static_cast<std::size_t>(c)] != 0;
  }
  // The cells of `pose` that earn: all of them, or those in the area
  // (copied into `scratch`, which the result then refers to).
  [[nodiscard]] const std::vector<int>& EarningCells(const PoseObservation& pose,
                                                     std::vector<int>& scratch) const;

  const Eigen::VectorXd& mean_;
  const Eigen::MatrixXd& cov_;
  InformationParams params_;
  std::span<const std::uint8_t> area_;
  std::vector<PoseObservation> prefix_;
  std::shared_ptr<const Eigen::MatrixXd> conditioned_;  // P_c, null without a prefix
  mutable Eigen::MatrixXd base_squared_;
  mutable double work_without_square_ = 0.0;  // multiply-adds, see UseBaseSquared
  mutable std::int64_t prefix_misses_ = 0;
};

// The oracle: sequential full Kalman covariance updates on a copy of the
// covariance, reading the variances before each pose (adaptive) or the trace
// before and after (non-adaptive). O(n^2) memory and O(n^2 m) time per pose.
// `area` as InformationEvaluator's: the adaptive sum skips cells outside
// it, the trace counts only cells inside it.
[[nodiscard]] double ReferenceInformation(const Eigen::VectorXd& mean,
                                          const Eigen::MatrixXd& covariance,
                                          const InformationParams& params,
                                          std::span<const PoseObservation> poses,
                                          std::span<const std::uint8_t> area = {});

}  // namespace oaipp
