#include "core/trajectory/min_snap.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <optional>
#include <utility>

#include "Eigen/Cholesky"
#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"
#include "core/trajectory/internal/polynomial_basis.h"

namespace oaipp {
namespace {

using internal::kNumCoefficients;
using internal::kNumEndpointDerivatives;
using internal::Matrix10;

// Derivatives 1..4 are the unknowns at an interior waypoint.
constexpr int kFree = kNumEndpointDerivatives - 1;
using Block = Eigen::Matrix<double, kFree, kFree>;
using BlockRhs = Eigen::Matrix<double, kFree, 3>;
using Endpoints = Eigen::Matrix<double, kNumCoefficients, 3>;

// Derivative order of row `row` of a segment's endpoint vector.
constexpr int OrderOf(int row) { return row % kNumEndpointDerivatives; }

// Cost of one segment of duration T as a quadratic form in its endpoint
// derivatives in REAL time: with d_s = S d_t, S = diag(T^r),
//   J = T^-7 d_s^T H d_s = d_t^T (T^-7 S H S) d_t.
Matrix10 SegmentCostMatrix(double T) {
  const Matrix10& h = internal::Basis().snap_cost_endpoints;
  // T^(r_a + r_b - 7) for r_a + r_b in 0..8.
  double powers[2 * kNumEndpointDerivatives - 1];
  powers[0] = std::pow(T, -7);
  for (int e = 1; e < 2 * kNumEndpointDerivatives - 1; ++e) powers[e] = powers[e - 1] * T;
  Matrix10 m;
  for (int a = 0; a < kNumCoefficients; ++a) {
    for (int b = 0; b < kNumCoefficients; ++b) m(a, b) = h(a, b) * powers[OrderOf(a) + OrderOf(b)];
  }
  return m;
}

absl::Status CheckFiniteAt(absl::string_view field, size_t index, const Vec3& v) {
  return CheckFinite(absl::StrCat(field, "[", index, "]"), v);
}

// Solves the SPD block-tridiagonal system
//   D_i x_i + B_{i-1}^T x_{i-1} + B_i x_{i+1} = r_i
// by block LDL^T (block Cholesky); the Schur complements stay SPD. Returns
// false if one is numerically not positive definite.
bool SolveBlockTridiagonal(std::vector<Block> diag, const std::vector<Block>& upper,
                           std::vector<BlockRhs>& rhs_then_solution) {
  const size_t n = diag.size();
  std::vector<BlockRhs>& x = rhs_then_solution;
  std::vector<Eigen::LLT<Block>> schur(n);
  for (size_t i = 0; i < n; ++i) {
    if (i > 0) {
      // S_i = D_i - B^T S_{i-1}^-1 B, z_i = r_i - B^T S_{i-1}^-1 z_{i-1}.
      const Block s_inv_b = schur[i - 1].solve(upper[i - 1]);
      diag[i] -= upper[i - 1].transpose() * s_inv_b;
      x[i] -= s_inv_b.transpose() * x[i - 1];
    }
    schur[i].compute(diag[i]);
    if (schur[i].info() != Eigen::Success) return false;
  }
  x[n - 1] = schur[n - 1].solve(x[n - 1]);
  for (size_t i = n - 1; i-- > 0;) x[i] = schur[i].solve(x[i] - upper[i] * x[i + 1]);
  return true;
}

}  // namespace

absl::Status ValidateLimits(const TrajectoryLimits& limits) {
  OAIPP_RETURN_IF_ERROR(CheckPositive("limits.max_speed_m_s", limits.max_speed_m_s));
  return CheckPositive("limits.max_accel_m_s2", limits.max_accel_m_s2);
}

double RampSegmentTime(double distance_m, const TrajectoryLimits& limits) {
  assert(distance_m >= 0.0);
  assert(ValidateLimits(limits).ok());
  const double v = limits.max_speed_m_s, a = limits.max_accel_m_s2;
  // Below v^2 / a the ramp is a triangle (accelerate half way, then brake).
  if (distance_m < v * v / a) return 2.0 * std::sqrt(distance_m / a);
  return 2.0 * v / a + (distance_m - v * v / a) / v;
}

absl::StatusOr<PolynomialTrajectory> SolveMinSnap(const std::vector<Vec3>& waypoints_W,
                                                  const std::vector<double>& segment_durations_s,
                                                  const Vec3& start_velocity_W_m_s,
                                                  const Vec3& start_accel_W_m_s2,
                                                  bool free_start_jerk_snap) {
  if (waypoints_W.size() < 2) {
    return absl::InvalidArgumentError(
        absl::StrCat("waypoints_W: need at least 2 waypoints, got ", waypoints_W.size()));
  }
  if (segment_durations_s.size() + 1 != waypoints_W.size()) {
    return absl::InvalidArgumentError(absl::StrCat("segment_durations_s: need one per segment (",
                                                   waypoints_W.size() - 1, "), got ",
                                                   segment_durations_s.size()));
  }
  for (size_t i = 0; i < waypoints_W.size(); ++i) {
    OAIPP_RETURN_IF_ERROR(CheckFiniteAt("waypoints_W", i, waypoints_W[i]));
  }
  for (size_t i = 0; i < segment_durations_s.size(); ++i) {
    OAIPP_RETURN_IF_ERROR(
        CheckPositive(absl::StrCat("segment_durations_s[", i, "]"), segment_durations_s[i]));
  }
  OAIPP_RETURN_IF_ERROR(CheckFinite("start_velocity_W_m_s", start_velocity_W_m_s));
  OAIPP_RETURN_IF_ERROR(CheckFinite("start_accel_W_m_s2", start_accel_W_m_s2));

  const size_t num_segments = segment_durations_s.size();
  const size_t num_free = num_segments - 1;  // interior waypoints

  // Known endpoint values of each segment (free slots zero): positions
  // everywhere, (v0, a0, 0, 0) at the start, rest at the end.
  std::vector<Matrix10> cost(num_segments);
  std::vector<Endpoints> fixed(num_segments, Endpoints::Zero());
  for (size_t j = 0; j < num_segments; ++j) {
    cost[j] = SegmentCostMatrix(segment_durations_s[j]);
    fixed[j].row(0) = waypoints_W[j].transpose();
    fixed[j].row(kNumEndpointDerivatives) = waypoints_W[j + 1].transpose();
  }
  fixed[0].row(1) = start_velocity_W_m_s.transpose();
  fixed[0].row(2) = start_accel_W_m_s2.transpose();

  // Free start jerk and snap (rows 3, 4 of segment 0) touch only that
  // segment's cost, so they are minimised out in closed form: with F = {3, 4}
  // and G = M_FF^-1 M_F,rest, the optimum is d_F = -G d_rest and the cost
  // of the rest is the Schur complement M - M_:F G.
  Eigen::Matrix<double, 2, kNumCoefficients> start_gain =
      Eigen::Matrix<double, 2, kNumCoefficients>::Zero();
  if (free_start_jerk_snap) {
    const Eigen::Matrix2d m_ff = cost[0].block<2, 2>(3, 3);
    const Eigen::LLT<Eigen::Matrix2d> llt(m_ff);
    if (llt.info() != Eigen::Success) {
      return absl::InternalError("SolveMinSnap: degenerate first segment (duration out of range?)");
    }
    start_gain = llt.solve(cost[0].block<2, kNumCoefficients>(3, 0));
    start_gain.block<2, 2>(0, 3).setZero();
    cost[0] -= cost[0].block<kNumCoefficients, 2>(0, 3) * start_gain;
    cost[0].block<2, kNumCoefficients>(3, 0).setZero();
    cost[0].block<kNumCoefficients, 2>(0, 3).setZero();
  }

  // Stationarity of sum_j d_j^T M_j d_j in the free derivatives (Richter et
  // al. 2016, unconstrained QP: d_P = -R_PP^-1 R_FP^T d_F) is a block
  // tridiagonal system: interior node i couples only to its neighbours. All three axes share
  // the matrix, so it is factored once for three right-hand sides.
  std::vector<Block> diag(num_free, Block::Zero());
  std::vector<Block> upper(num_free > 0 ? num_free - 1 : 0);
  std::vector<BlockRhs> rhs(num_free, BlockRhs::Zero());
  for (size_t j = 0; j < num_segments; ++j) {
    const Endpoints grad_fixed = cost[j] * fixed[j];
    if (j >= 1) {  // node j is free
      diag[j - 1] += cost[j].block<kFree, kFree>(1, 1);
      rhs[j - 1] -= grad_fixed.block<kFree, 3>(1, 0);
    }
    if (j + 1 <= num_free) {  // node j + 1 is free
      diag[j] += cost[j].block<kFree, kFree>(6, 6);
      rhs[j] -= grad_fixed.block<kFree, 3>(6, 0);
    }
    if (j >= 1 && j + 1 <= num_free) upper[j - 1] = cost[j].block<kFree, kFree>(1, 6);
  }

  // Jacobi scaling: velocity and snap entries differ by T^6, up to 1e10.
  std::vector<Eigen::Matrix<double, kFree, 1>> scale(num_free);
  for (size_t i = 0; i < num_free; ++i) {
    scale[i] = diag[i].diagonal().cwiseSqrt().cwiseInverse();
    if (!AllFinite(scale[i])) {
      return absl::InternalError("SolveMinSnap: degenerate system (durations out of range?)");
    }
  }
  for (size_t i = 0; i < num_free; ++i) {
    diag[i] = scale[i].asDiagonal() * diag[i] * scale[i].asDiagonal();
    rhs[i] = scale[i].asDiagonal() * rhs[i];
    if (i + 1 < num_free) upper[i] = scale[i].asDiagonal() * upper[i] * scale[i + 1].asDiagonal();
  }
  if (num_free > 0 && !SolveBlockTridiagonal(std::move(diag), upper, rhs)) {
    return absl::InternalError(
        "SolveMinSnap: system not numerically positive definite (durations span too many orders "
        "of magnitude)");
  }

  // Coefficients per segment: c = A^-1 S(T) d_t, in long double (see
  // PolynomialBasis::coeffs_from_endpoints).
  const internal::Matrix10L& coeffs_from_endpoints = internal::Basis().coeffs_from_endpoints;
  using EndpointsL = Eigen::Matrix<long double, kNumCoefficients, 3>;
  std::vector<Endpoints> coefficients(num_segments);
  for (size_t j = 0; j < num_segments; ++j) {
    Endpoints d = fixed[j];
    if (j >= 1) d.block<kFree, 3>(1, 0) = scale[j - 1].asDiagonal() * rhs[j - 1];
    if (j + 1 <= num_free) d.block<kFree, 3>(6, 0) = scale[j].asDiagonal() * rhs[j];
    if (j == 0 && free_start_jerk_snap) d.block<2, 3>(3, 0) = -start_gain * d;
    const long double T = segment_durations_s[j];
    EndpointsL d_s = d.cast<long double>();
    long double t_power = 1.0L;  // T^r
    for (int r = 0; r < kNumEndpointDerivatives; ++r, t_power *= T) {
      d_s.row(r) *= t_power;
      d_s.row(kNumEndpointDerivatives + r) *= t_power;
    }
    coefficients[j] = (coeffs_from_endpoints * d_s).cast<double>();
    if (!AllFinite(coefficients[j])) {
      return absl::InternalError(
          absl::StrCat("SolveMinSnap: non-finite coefficients in segment ", j));
    }
  }
  return PolynomialTrajectory(waypoints_W, segment_durations_s, std::move(coefficients));
}

namespace {

// Relative slack on the limits, and how close to a limit the scaled
// trajectory must come to count as the fastest.
constexpr double kLimitTolerance = 1e-6;
constexpr double kTightness = 1e-3;
// Waypoints closer than this are merged.
constexpr double kMergeDistance_m = 1e-6;
// Lower bound on the allocated (unscaled) segment time.
constexpr double kMinSegmentTime_s = 0.1;
constexpr int kMaxFixedPointIterations = 12;
// The fixed-point iteration gives up outside these scales (durations from
// 1/100 to 1000 times the ramp times).
constexpr double kMinScale = 1e-2;
constexpr double kMaxScale = 1e3;
constexpr int kMaxBisections = 25;
// The fallback scan: k_ref * kScanStep^j for j in [kScanFirst, kScanLast].
constexpr double kScanStep = 1.25;
constexpr int kScanFirst = -4;
constexpr int kScanLast = 24;

struct Evaluation {
  double ratio = 0.0;  // max(speed / v_max, sqrt(accel / a_max))
  bool feasible = false;
};

class ScaleSearch {
 public:
  ScaleSearch(const StartState& start, std::vector<Vec3> waypoints_W,
              std::vector<double> base_durations_s, const TrajectoryLimits& limits,
              bool free_start_jerk_snap, bool fixed_first = false)
      : start_(start),
        waypoints_W_(std::move(waypoints_W)),
        base_durations_s_(std::move(base_durations_s)),
        limits_(limits),
        free_start_jerk_snap_(free_start_jerk_snap),
        fixed_first_(fixed_first) {}

  absl::StatusOr<PolynomialTrajectory> Run() {
    // From rest the speed scales as 1/k and the acceleration as 1/k^2, so
    // k <- k * ratio / target lands on the target in one step, and the
    // target is the limit itself. Otherwise the ratio is only roughly
    // proportional to 1/k: aim at the middle of the accepted window
    // [1 - kTightness, 1], with secant steps on log(ratio) against log(k).
    const bool from_rest = start_.velocity_W_m_s.isZero(0.0) && start_.accel_W_m_s2.isZero(0.0);
    const double target = from_rest ? 1.0 : 1.0 - 0.5 * kTightness;
    double k = 1.0;
    double k_ref = 0.0;
    double prev_log_k = 0.0, prev_log_ratio = 0.0;
    for (int iter = 0; iter < kMaxFixedPointIterations; ++iter) {
      OAIPP_ASSIGN_OR_RETURN(const Evaluation e, Evaluate(k));
      // A zero ratio is a trajectory that never moves: nothing to scale.
      if (e.feasible && (e.ratio >= 1.0 - kTightness || e.ratio == 0.0)) {
        return best_feasible_->trajectory;
      }
      if (iter == 0) k_ref = k * e.ratio;
      const double log_k = std::log(k), log_ratio = std::log(e.ratio);
      double slope = -1.0;
      if (iter > 0 && log_k != prev_log_k) {
        const double secant = (log_ratio - prev_log_ratio) / (log_k - prev_log_k);
        // Only trust a secant that says "longer is slower", as expected.
        if (secant < -0.1) slope = secant;
      }
      prev_log_k = log_k;
      prev_log_ratio = log_ratio;
      // Limit the step: with a large start acceleration the ratio can grow
      // with k, and an unlimited step would run away.
      k *= std::clamp(std::exp((std::log(target) - log_ratio) / slope), 0.25, 4.0);
      if (const auto bracket = Bracket();
          bracket && (k <= bracket->first || k >= bracket->second)) {
        k = std::sqrt(bracket->first * bracket->second);
      }
      if (k < kMinScale || k > kMaxScale) break;
    }
    if (!best_feasible_) {
      // Scan around the from-rest estimate for any feasible scale.
      for (int j = kScanFirst; j <= kScanLast && !best_feasible_; ++j) {
        OAIPP_RETURN_IF_ERROR(Evaluate(k_ref * std::pow(kScanStep, j)).status());
      }
    }
    if (!best_feasible_) {
      return absl::FailedPreconditionError(absl::StrCat(
          "PlanMinSnap: no common scaling of the segment times meets the limits from this start "
          "state (start speed ",
          start_.velocity_W_m_s.norm(), " m/s, start acceleration ", start_.accel_W_m_s2.norm(),
          " m/s^2)"));
    }
    // Geometric bisection between the largest infeasible scale below the
    // smallest feasible one and that feasible one.
    for (int iter = 0; iter < kMaxBisections; ++iter) {
      const auto bracket = Bracket();
      if (!bracket || bracket->second / bracket->first < 1.0 + kTightness) break;
      OAIPP_RETURN_IF_ERROR(Evaluate(std::sqrt(bracket->first * bracket->second)).status());
    }
    return best_feasible_->trajectory;
  }

 private:
  struct Feasible {
    double scale;  // k: the durations are k times the ramp times
    PolynomialTrajectory trajectory;
  };

  // Solves with the durations scaled by k; remembers k when infeasible and
  // the trajectory when it is the fastest feasible so far.
  absl::StatusOr<Evaluation> Evaluate(double k) {
    std::vector<double> durations_s = base_durations_s_;
    for (std::size_t i = fixed_first_ ? 1 : 0; i < durations_s.size(); ++i) durations_s[i] *= k;
    OAIPP_ASSIGN_OR_RETURN(PolynomialTrajectory trajectory,
                           SolveMinSnap(waypoints_W_, durations_s, start_.velocity_W_m_s,
                                        start_.accel_W_m_s2, free_start_jerk_snap_));
    const double speed_ratio = trajectory.MaxSpeed() / limits_.max_speed_m_s;
    const double accel_ratio = trajectory.MaxAcceleration() / limits_.max_accel_m_s2;
    const Evaluation e{
        .ratio = std::max(speed_ratio, std::sqrt(accel_ratio)),
        .feasible = speed_ratio <= 1.0 + kLimitTolerance && accel_ratio <= 1.0 + kLimitTolerance};
    if (!e.feasible) {
      infeasible_scales_.push_back(k);
    } else if (!best_feasible_ || k < best_feasible_->scale) {
      best_feasible_.emplace(Feasible{k, std::move(trajectory)});
    }
    return e;
  }

  // (largest infeasible scale below the smallest feasible one, that one).
  std::optional<std::pair<double, double>> Bracket() const {
    if (!best_feasible_) return std::nullopt;
    double lo = 0.0;
    for (double k : infeasible_scales_) {
      if (k < best_feasible_->scale) lo = std::max(lo, k);
    }
    if (lo == 0.0) return std::nullopt;
    return std::make_pair(lo, best_feasible_->scale);
  }

  const StartState start_;
  const std::vector<Vec3> waypoints_W_;
  const std::vector<double> base_durations_s_;
  const TrajectoryLimits limits_;
  const bool free_start_jerk_snap_;
  const bool fixed_first_;  // the first segment keeps its duration
  std::optional<Feasible> best_feasible_;
  std::vector<double> infeasible_scales_;
};

}  // namespace

absl::StatusOr<PolynomialTrajectory> PlanMinSnap(const StartState& start,
                                                 const std::vector<Vec3>& waypoints_after_start_W,
                                                 const TrajectoryLimits& limits) {
  OAIPP_RETURN_IF_ERROR(ValidateLimits(limits));
  OAIPP_RETURN_IF_ERROR(CheckFinite("start.position_W", start.position_W));
  OAIPP_RETURN_IF_ERROR(CheckFinite("start.velocity_W_m_s", start.velocity_W_m_s));
  OAIPP_RETURN_IF_ERROR(CheckFinite("start.accel_W_m_s2", start.accel_W_m_s2));
  if (waypoints_after_start_W.empty()) {
    return absl::InvalidArgumentError("waypoints_after_start_W: need at least one waypoint");
  }
  for (size_t i = 0; i < waypoints_after_start_W.size(); ++i) {
    OAIPP_RETURN_IF_ERROR(CheckFiniteAt("waypoints_after_start_W", i, waypoints_after_start_W[i]));
  }
  const double start_speed_m_s = start.velocity_W_m_s.norm();
  if (start_speed_m_s > limits.max_speed_m_s * (1.0 + kLimitTolerance)) {
    return absl::FailedPreconditionError(
        absl::StrCat("start.velocity_W_m_s: speed ", start_speed_m_s,
                     " m/s exceeds limits.max_speed_m_s = ", limits.max_speed_m_s));
  }
  const double start_accel_m_s2 = start.accel_W_m_s2.norm();
  if (start_accel_m_s2 > limits.max_accel_m_s2 * (1.0 + kLimitTolerance)) {
    return absl::FailedPreconditionError(
        absl::StrCat("start.accel_W_m_s2: acceleration ", start_accel_m_s2,
                     " m/s^2 exceeds limits.max_accel_m_s2 = ", limits.max_accel_m_s2));
  }

  std::vector<Vec3> waypoints_W{start.position_W};
  for (const Vec3& w : waypoints_after_start_W) {
    if ((w - waypoints_W.back()).norm() >= kMergeDistance_m) waypoints_W.push_back(w);
  }
  // Everything merged into the start: one segment back to it.
  if (waypoints_W.size() == 1) waypoints_W.push_back(start.position_W);

  std::vector<double> durations_s;
  durations_s.reserve(waypoints_W.size() - 1);
  for (size_t i = 0; i + 1 < waypoints_W.size(); ++i) {
    durations_s.push_back(std::max(
        kMinSegmentTime_s, RampSegmentTime((waypoints_W[i + 1] - waypoints_W[i]).norm(), limits)));
  }
  // The first segment must also cancel the part of the start velocity that
  // does not carry the UAV towards its end (sideways or backwards), which
  // takes |v_off| / a_max at full acceleration. Without this, the common
  // scale factor has to slow every segment down for the first one's sake
  // (and often fails at all near full speed).
  const Vec3 first_W = waypoints_W[1] - waypoints_W[0];
  Vec3 towards_W = Vec3::Zero();
  if (first_W.norm() > 0.0) towards_W = first_W.normalized();
  const Vec3 off_velocity_W_m_s =
      start.velocity_W_m_s - std::max(0.0, start.velocity_W_m_s.dot(towards_W)) * towards_W;
  durations_s[0] += off_velocity_W_m_s.norm() / limits.max_accel_m_s2;
  // From a moving start the start jerk and snap are left to the optimiser:
  // the state carries no jerk, and held at 0 they would make the start
  // acceleration last a fixed fraction of the first segment, so that long
  // durations overshoot the speed while short ones break the acceleration
  // limit. Freed, the acceleration fades quickly; the scaled trajectories
  // are shorter and the search settles in fewer solves. At rest (AtRest,
  // which takes in a path's end state) both are 0.
  const bool moving = !start.velocity_W_m_s.isZero(0.0) || !start.accel_W_m_s2.isZero(0.0);
  const bool free_jerk = !AtRest(start.velocity_W_m_s, start.accel_W_m_s2);
  absl::StatusOr<PolynomialTrajectory> planned =
      ScaleSearch(start, waypoints_W, durations_s, limits, free_jerk).Run();
  if (planned.ok() || !moving || planned.status().code() != absl::StatusCode::kFailedPrecondition) {
    return planned;
  }
  if (!free_jerk) {
    absl::StatusOr<PolynomialTrajectory> freed =
        ScaleSearch(start, waypoints_W, durations_s, limits, /*free_start_jerk_snap=*/true).Run();
    if (freed.ok()) return freed;
  }
  // A minimum-snap segment cannot cruise: a fast start and a long first
  // segment still overshoot. A transition segment of fixed duration tau then
  // carries on at the current velocity, to p + v tau (the free start jerk
  // lets the start acceleration fade within it), and only the segments
  // after it are scaled.
  for (double tau_s : {1.0, 2.0}) {
    std::vector<Vec3> via{start.position_W, start.position_W + start.velocity_W_m_s * tau_s};
    std::vector<double> via_durations{tau_s};
    for (std::size_t i = 1; i < waypoints_W.size(); ++i) {
      const double d = (waypoints_W[i] - via.back()).norm();
      if (d < kMergeDistance_m) continue;
      via_durations.push_back(std::max(kMinSegmentTime_s, RampSegmentTime(d, limits)));
      via.push_back(waypoints_W[i]);
    }
    absl::StatusOr<PolynomialTrajectory> t =
        ScaleSearch(start, std::move(via), std::move(via_durations), limits,
                    /*free_start_jerk_snap=*/true, /*fixed_first=*/true)
            .Run();
    if (t.ok()) return t;
  }
  return planned;
}

bool AtRest(const Vec3& velocity_W_m_s, const Vec3& accel_W_m_s2) {
  return velocity_W_m_s.norm() <= 1e-6 && accel_W_m_s2.norm() <= 1e-6;
}

absl::StatusOr<PolynomialTrajectory> PlanStopAndGo(const std::vector<Vec3>& points_W,
                                                   const TrajectoryLimits& limits) {
  OAIPP_RETURN_IF_ERROR(ValidateLimits(limits));
  if (points_W.empty()) return absl::InvalidArgumentError("points_W: need at least one point");
  for (size_t i = 0; i < points_W.size(); ++i) {
    OAIPP_RETURN_IF_ERROR(CheckFiniteAt("points_W", i, points_W[i]));
  }
  std::vector<double> durations_s;
  std::vector<PolynomialTrajectory::SegmentCoefficients> coefficients;
  Vec3 from = points_W.front();
  for (size_t i = 1; i < points_W.size(); ++i) {
    if ((points_W[i] - from).norm() < kMergeDistance_m) continue;
    OAIPP_ASSIGN_OR_RETURN(PolynomialTrajectory leg,
                           PlanMinSnap(StartState{.position_W = from}, {points_W[i]}, limits));
    for (int j = 0; j < leg.NumSegments(); ++j) {
      durations_s.push_back(leg.SegmentDurations()[j]);
      coefficients.push_back(leg.Coefficients(j));
    }
    from = points_W[i];
  }
  if (durations_s.empty()) return PlanMinSnap(StartState{.position_W = from}, {from}, limits);
  return PolynomialTrajectory::FromCoefficients(std::move(durations_s), coefficients);
}

}  // namespace oaipp
