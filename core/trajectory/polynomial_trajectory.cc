#include "core/trajectory/polynomial_trajectory.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/trajectory/internal/polynomial_basis.h"

namespace oaipp {
namespace {

static_assert(PolynomialTrajectory::kNumCoefficients == internal::kNumCoefficients);

using internal::FallingFactorial;
using Coeffs = PolynomialTrajectory::SegmentCoefficients;

// Coefficients in s of d^order p / ds^order (rows 0 .. kDegree - order).
Coeffs DifferentiateInS(const Coeffs& c, int order) {
  Coeffs d = Coeffs::Zero();
  for (int k = order; k < PolynomialTrajectory::kNumCoefficients; ++k) {
    d.row(k - order) = FallingFactorial(k, order) * c.row(k);
  }
  return d;
}

// Horner evaluation of the first `count` rows of `c` at s.
Vec3 Evaluate(const Coeffs& c, int count, double s) {
  Vec3 v = Vec3::Zero();
  for (int k = count - 1; k >= 0; --k) v = v * s + c.row(k).transpose();
  return v;
}

// d^order p / dtau^order at tau of sum_k c_k tau^k, by Horner's scheme with
// derivatives: d[j] accumulates the j-th derivative divided by j!, all in one
// pass over the coefficients (order <= kDegree).
Vec3 EvaluateRealTime(const Coeffs& c, double tau, int order) {
  Vec3 d[PolynomialTrajectory::kNumCoefficients];
  for (int j = 0; j <= order; ++j) d[j] = Vec3::Zero();
  for (int k = PolynomialTrajectory::kNumCoefficients - 1; k >= 0; --k) {
    for (int j = order; j >= 1; --j) d[j] = d[j] * tau + d[j - 1];
    d[0] = d[0] * tau + c.row(k).transpose();
  }
  double factorial = 1.0;
  for (int j = 2; j <= order; ++j) factorial *= j;
  return factorial * d[order];
}

// Number of samples per segment for the maximum searches, and the
// golden-section iterations that shrink a bracket of width 2/64 to ~2e-8
// (the value error is second order in that: ~1e-13 relative).
constexpr int kMaxSearchIntervals = 64;
constexpr int kGoldenIterations = 30;

// Golden-section search for the maximum of f on [lo, hi]; f is assumed
// unimodal there (a bracket around a sampled local maximum).
template <typename F>
double GoldenMax(const F& f, double lo, double hi) {
  constexpr double kInvPhi = 0.6180339887498949;
  double a = hi - kInvPhi * (hi - lo), b = lo + kInvPhi * (hi - lo);
  double fa = f(a), fb = f(b);
  for (int i = 0; i < kGoldenIterations; ++i) {
    if (fa < fb) {
      lo = a;
      a = b;
      fa = fb;
      b = lo + kInvPhi * (hi - lo);
      fb = f(b);
    } else {
      hi = b;
      b = a;
      fb = fa;
      a = hi - kInvPhi * (hi - lo);
      fa = f(a);
    }
  }
  return std::max(fa, fb);
}

}  // namespace

PolynomialTrajectory::PolynomialTrajectory(std::vector<Vec3> waypoints_W,
                                           std::vector<double> durations_s,
                                           std::vector<NormalizedCoefficients> coefficients)
    : waypoints_W_(std::move(waypoints_W)),
      durations_s_(std::move(durations_s)),
      coefficients_(std::move(coefficients)) {
  assert(!durations_s_.empty());
  assert(waypoints_W_.size() == durations_s_.size() + 1);
  assert(coefficients_.size() == durations_s_.size());
  start_times_s_.reserve(durations_s_.size() + 1);
  double t = 0.0;
  for (double d : durations_s_) {
    start_times_s_.push_back(t);
    t += d;
  }
  start_times_s_.push_back(t);
  duration_s_ = t;
}

absl::StatusOr<PolynomialTrajectory> PolynomialTrajectory::FromCoefficients(
    std::vector<double> durations_s, const std::vector<SegmentCoefficients>& coefficients) {
  if (durations_s.empty()) return absl::InvalidArgumentError("durations_s: needs a segment");
  if (coefficients.size() != durations_s.size()) {
    return absl::InvalidArgumentError(absl::StrCat("coefficients: has ", coefficients.size(),
                                                   " segments, durations_s ", durations_s.size()));
  }
  std::vector<NormalizedCoefficients> normalized(durations_s.size());
  std::vector<Vec3> waypoints_W;
  waypoints_W.reserve(durations_s.size() + 1);
  for (std::size_t i = 0; i < durations_s.size(); ++i) {
    const double T = durations_s[i];
    if (absl::Status s = CheckPositive(absl::StrCat("durations_s[", i, "]"), T); !s.ok()) return s;
    if (!coefficients[i].allFinite()) {
      return absl::InvalidArgumentError(absl::StrCat("coefficients[", i, "]: must be finite"));
    }
    // c_k tau^k = (c_k T^k) s^k.
    double scale = 1.0;
    for (int k = 0; k < kNumCoefficients; ++k) {
      normalized[i].row(k) = coefficients[i].row(k) * scale;
      scale *= T;
    }
    waypoints_W.push_back(normalized[i].row(0).transpose());
  }
  waypoints_W.push_back(normalized.back().colwise().sum().transpose());
  PolynomialTrajectory out(std::move(waypoints_W), std::move(durations_s), std::move(normalized));
  out.real_time_coefficients_ = coefficients;
  return out;
}

double PolynomialTrajectory::SegmentStartTime(int segment) const {
  assert(segment >= 0 && segment <= NumSegments());
  return start_times_s_[segment];
}

int PolynomialTrajectory::SegmentIndex(double t_s) const {
  // The last segment whose start is <= t; at an interior waypoint that is
  // the later segment.
  const auto it = std::upper_bound(start_times_s_.begin(), start_times_s_.end() - 1, t_s);
  const int index = static_cast<int>(it - start_times_s_.begin()) - 1;
  return std::clamp(index, 0, NumSegments() - 1);
}

Vec3 PolynomialTrajectory::Derivative(double t_s, int order) const {
  assert(order >= 0);
  if (order > kDegree) return Vec3::Zero();
  const double t = std::clamp(t_s, 0.0, duration_s_);
  const int i = SegmentIndex(t);
  const double T = durations_s_[i];
  if (!real_time_coefficients_.empty()) {
    return EvaluateRealTime(real_time_coefficients_[i], std::clamp(t - start_times_s_[i], 0.0, T),
                            order);
  }
  const double s = std::clamp((t - start_times_s_[i]) / T, 0.0, 1.0);
  // d^r/dt^r = T^-r d^r/ds^r.
  return Evaluate(DifferentiateInS(coefficients_[i], order), kNumCoefficients - order, s) /
         std::pow(T, order);
}

PolynomialTrajectory::SegmentCoefficients PolynomialTrajectory::Coefficients(int segment) const {
  assert(segment >= 0 && segment < NumSegments());
  if (!real_time_coefficients_.empty()) return real_time_coefficients_[segment];
  // c_k s^k = (c_k / T^k) tau^k.
  SegmentCoefficients c = coefficients_[segment];
  const double inv_T = 1.0 / durations_s_[segment];
  double scale = 1.0;
  for (int k = 0; k < kNumCoefficients; ++k) {
    c.row(k) *= scale;
    scale *= inv_T;
  }
  return c;
}

double PolynomialTrajectory::SnapCost() const {
  const internal::Matrix10& q = internal::Basis().snap_cost_coeffs;
  double cost = 0.0;
  for (int i = 0; i < NumSegments(); ++i) {
    const NormalizedCoefficients& c = coefficients_[i];
    // Integral over tau of (T^-4 p_ssss)^2 = T^-7 c^T Q c.
    cost += (c.transpose() * q * c).trace() / std::pow(durations_s_[i], 7);
  }
  return cost;
}

double PolynomialTrajectory::MaxNorm(int order) const {
  double max_sq = 0.0;
  for (int i = 0; i < NumSegments(); ++i) {
    const Coeffs d = DifferentiateInS(coefficients_[i], order);
    const int count = kNumCoefficients - order;
    const double scale = std::pow(durations_s_[i], -order);
    const auto norm_sq = [&](double s) { return (scale * Evaluate(d, count, s)).squaredNorm(); };
    double samples[kMaxSearchIntervals + 1];
    for (int j = 0; j <= kMaxSearchIntervals; ++j) {
      samples[j] = norm_sq(static_cast<double>(j) / kMaxSearchIntervals);
      max_sq = std::max(max_sq, samples[j]);
    }
    for (int j = 0; j <= kMaxSearchIntervals; ++j) {
      const bool left_ok = j == 0 || samples[j] >= samples[j - 1];
      const bool right_ok = j == kMaxSearchIntervals || samples[j] >= samples[j + 1];
      if (!left_ok || !right_ok) continue;
      const double lo = static_cast<double>(std::max(j - 1, 0)) / kMaxSearchIntervals;
      const double hi =
          static_cast<double>(std::min(j + 1, kMaxSearchIntervals)) / kMaxSearchIntervals;
      max_sq = std::max(max_sq, GoldenMax(norm_sq, lo, hi));
    }
  }
  return std::sqrt(max_sq);
}

absl::StatusOr<std::vector<TimedPosition>> SampleTrajectory(const PolynomialTrajectory& trajectory,
                                                            double rate_hz) {
  if (absl::Status s = CheckPositive("rate_hz", rate_hz); !s.ok()) return s;
  constexpr double kMaxSamples = 1e7;
  const double duration_s = trajectory.Duration();
  if (duration_s * rate_hz > kMaxSamples) {
    return absl::InvalidArgumentError(absl::StrCat("rate_hz: ", rate_hz, " Hz over ", duration_s,
                                                   " s exceeds ", kMaxSamples, " samples"));
  }
  std::vector<TimedPosition> samples;
  samples.reserve(static_cast<size_t>(duration_s * rate_hz) + 2);
  // t = j / rate rather than accumulating 1/rate, so times do not drift.
  for (int j = 0;; ++j) {
    const double t_s = j / rate_hz;
    if (t_s >= duration_s) break;
    samples.push_back({t_s, trajectory.Position(t_s)});
  }
  samples.push_back({duration_s, trajectory.Position(duration_s)});
  return samples;
}

}  // namespace oaipp
