#include "core/mapping/gp_params.h"

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
  return CheckPositive("width_m", width_m);
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
