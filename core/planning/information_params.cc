#include "core/planning/information.h"

// The objective's parameters (their checks and the confirmation phase), the
// altitude reward and the chance that a look misclassifies a cell: the
// scalar parts of the information objective, kept apart from the evaluator's
// matrix code in information.cc.

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "boost/math/special_functions/owens_t.hpp"
#include "core/common/geometry.h"

namespace oaipp {

absl::Status InformationParams::Validate() const {
  if (!(kappa >= 0.0) || !std::isfinite(kappa)) {
    return absl::InvalidArgumentError(absl::StrCat("kappa: must be >= 0 and finite, got ", kappa));
  }
  if (auto s = CheckFinite("h_opt_m", h_opt_m); !s.ok()) return s;
  if (auto s = CheckPositive("sigma1_m", sigma1_m); !s.ok()) return s;
  if (auto s = CheckPositive("h_sat_m", h_sat_m); !s.ok()) return s;
  if (!(confirmation_weight >= 0.0) || !std::isfinite(confirmation_weight)) {
    return absl::InvalidArgumentError(
        absl::StrCat("confirmation_weight: must be >= 0 and finite, got ", confirmation_weight));
  }
  if (!(decision_threshold > 0.0 && decision_threshold < 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("decision_threshold: must lie in (0, 1), got ", decision_threshold));
  }
  if (confirmation_preposterior && !(confirmation_weight > 0.0)) {
    return absl::InvalidArgumentError(
        "confirmation_preposterior: requires confirmation_weight > 0");
  }
  if (confirmation_weight > 0.0 && kind != ObjectiveKind::kAdaptive) {
    return absl::InvalidArgumentError(
        "confirmation_weight: applies to the adaptive objective only, must be 0 for the "
        "trace-reduction objective");
  }
  if (!(confirmation_phase_s >= 0.0) || !std::isfinite(confirmation_phase_s)) {
    return absl::InvalidArgumentError(
        absl::StrCat("confirmation_phase_s: must be >= 0 and finite, got ", confirmation_phase_s));
  }
  if (!(confirmation_phase_weight >= 0.0) || !std::isfinite(confirmation_phase_weight)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "confirmation_phase_weight: must be >= 0 and finite, got ", confirmation_phase_weight));
  }
  if (!(second_look_weight >= 0.0) || !std::isfinite(second_look_weight)) {
    return absl::InvalidArgumentError(
        absl::StrCat("second_look_weight: must be >= 0 and finite, got ", second_look_weight));
  }
  if (!(second_look_sharpness >= 0.0) || !std::isfinite(second_look_sharpness)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "second_look_sharpness: must be >= 0 and finite, got ", second_look_sharpness));
  }
  if (!(ambiguity_margin > 0.0 && ambiguity_margin <= 0.5)) {
    return absl::InvalidArgumentError(
        absl::StrCat("ambiguity_margin: must lie in (0, 0.5], got ", ambiguity_margin));
  }
  if (!(detection_discount > 0.0 && detection_discount <= 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("detection_discount: must lie in (0, 1], got ", detection_discount));
  }
  if (confirmation_phase_s > 0.0 && kind != ObjectiveKind::kAdaptive) {
    return absl::InvalidArgumentError(
        "confirmation_phase_s: applies to the adaptive objective only, must be 0 for the "
        "trace-reduction objective");
  }
  return absl::OkStatus();
}

InformationParams InformationParams::ForRemainingBudget(double remaining_budget_s) const {
  InformationParams p = *this;
  if (kind == ObjectiveKind::kAdaptive && confirmation_phase_s > 0.0 &&
      remaining_budget_s <= confirmation_phase_s) {
    p.confirming = true;
    p.kappa = 0.0;
  }
  return p;
}

namespace {

// Owen's T in double precision throughout: Boost's default promotes to long
// double, about 1.4x slower for no gain at the accuracy the planner needs.
double OwensT(double h, double a) {
  using DoublePrecision =
      boost::math::policies::policy<boost::math::policies::promote_double<false>>;
  return boost::math::owens_t(h, a, DoublePrecision());
}

// P(misclassified) after observations that leave a cell believed
// N(mean, prior_variance) now with variance v, seen from now: the posterior
// mean then is N(mean, prior_variance - v) and the value around it
// N(0, v), so the two straddle the threshold with probability
// 2 T(h, sqrt(v / (prior_variance - v))), h = (threshold - mean) /
// sqrt(prior_variance); Phi(-|h|) when nothing is learned (v at the prior).
double MisclassifiedAfter(double h, double prior_variance, double v) {
  const double learned = prior_variance - v;
  if (!(learned > 1e-12 * prior_variance)) return 0.5 * std::erfc(std::abs(h) / std::sqrt(2.0));
  return 2.0 * OwensT(h, std::sqrt(std::max(v, 0.0) / learned));
}

}  // namespace

double MisclassificationReduction(double mean, double variance, double noise_variance,
                                  double threshold) {
  if (!(variance > 0.0)) return 0.0;
  const double sigma = std::sqrt(variance);
  const double h = (threshold - mean) / sigma;
  // M_before = Phi(-|h|); the true value X ~ N(mean, variance) and the
  // posterior mean after the observation are jointly normal with correlation
  // rho = sigma / sqrt(variance + r), and P(they straddle the threshold)
  // reduces to 2 T(h, sqrt(1 - rho^2) / rho) = 2 T(h, sqrt(r) / sigma).
  const double before = 0.5 * std::erfc(std::abs(h) / std::sqrt(2.0));
  const double after = 2.0 * OwensT(h, std::sqrt(std::max(noise_variance, 0.0)) / sigma);
  return std::max(before - after, 0.0);
}

double PreposteriorMisclassificationReduction(double mean, double prior_variance, double variance,
                                              double noise_variance, double threshold) {
  if (!(variance > 0.0) || !(prior_variance > 0.0)) return 0.0;
  const double h = (threshold - mean) / std::sqrt(prior_variance);
  const double r = std::max(noise_variance, 0.0);
  const double after = variance * r / (variance + r);  // this look's scalar update
  // A variance at or above the prior (rounding) learns nothing: Phi(-|h|).
  return std::max(MisclassifiedAfter(h, prior_variance, variance) -
                      MisclassifiedAfter(h, prior_variance, after),
                  0.0);
}

double InformationParams::AltitudeReward(double altitude_m) const {
  if (altitude_m >= h_sat_m) return 0.0;
  const double z = (altitude_m - h_opt_m) / sigma1_m;
  return std::exp(-0.5 * z * z) / (sigma1_m * std::sqrt(2.0 * kPi));
}

}  // namespace oaipp
