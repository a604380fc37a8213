#include "core/mapping/gp_params.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/common/geometry.h"
#include "core/common/status_macros.h"

namespace oaipp {

absl::Status GpParams::Validate() const {
  OAIPP_RETURN_IF_ERROR(CheckPositive("length_scale_m", length_scale_m));
  OAIPP_RETURN_IF_ERROR(CheckPositive("signal_var", signal_var));
  OAIPP_RETURN_IF_ERROR(CheckPositive("noise_var", noise_var));
  // The prior is computed as sn2 I - sn2^2 (K + sn2 I)^-1 (gp_map.cc), whose
  // round-off grows with sn2: far past the signal it swamps the covariance
  // (sn2 = 1e20 with sf2 = 0.3 made it indefinite).
  if (!(noise_var <= kMaxNoiseToSignal * signal_var)) {
    return absl::InvalidArgumentError(absl::StrCat("noise_var: must be at most ", kMaxNoiseToSignal,
                                                   " x signal_var (", signal_var, "), got ",
                                                   noise_var));
  }
  return CheckFinite("prior_mean", prior_mean);
}

absl::Status DetectorAccuracy::Validate() const {
  if (!(p_max > 0.0 && p_max < 1.0)) {
    return absl::InvalidArgumentError(absl::StrCat("p_max: must lie in (0, 1), got ", p_max));
  }
  if (!(h_best_m >= 0.0) || !std::isfinite(h_best_m)) {
    return absl::InvalidArgumentError(
        absl::StrCat("h_best_m: must be >= 0 and finite, got ", h_best_m));
  }
  OAIPP_RETURN_IF_ERROR(CheckPositive("width_m", width_m));
  if (false_positive_rate.has_value() &&
      !(*false_positive_rate > 0.0 && *false_positive_rate < 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("false_positive_rate: must lie in (0, 1), got ", *false_positive_rate));
  }
  return absl::OkStatus();
}

double DetectorAccuracy::LabelVariance(double altitude_m, double label) const {
  const double p = DetectionProbability(altitude_m);
  if (std::isnan(p)) return p;
  // A shift of the log-odds by s is a variance of 1 / (2 s); shifts below
  // 1 / (2 kMaxVariance) give the cap.
  const auto from_shift = [](double shift) {
    return shift * 2.0 * kMaxVariance > 1.0 ? 1.0 / (2.0 * shift) : kMaxVariance;
  };
  if (!false_positive_rate.has_value()) {
    return p * kMaxVariance > 1.0 - p ? (1.0 - p) / p : kMaxVariance;
  }
  const double q = *false_positive_rate;
  if (!(p > q)) return kMaxVariance;
  return label >= kDetectedLabel ? from_shift(std::log(p / q))
                                 : from_shift(std::log1p(-q) - std::log1p(-p));
}

absl::Status SensorNoise::Validate() const {
  OAIPP_RETURN_IF_ERROR(CheckPositive("a_var", a_var));
  OAIPP_RETURN_IF_ERROR(CheckPositive("b_per_m", b_per_m));
  if (!detector.has_value()) return absl::OkStatus();
  const absl::Status status = detector->Validate();
  if (status.ok()) return status;
  return absl::InvalidArgumentError(absl::StrCat("detector.", status.message()));
}

}  // namespace oaipp
