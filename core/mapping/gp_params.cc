#include "core/mapping/gp_params.h"

#include "core/common/geometry.h"
#include "core/common/status_macros.h"

namespace oaipp {

absl::Status GpParams::Validate() const {
  OAIPP_RETURN_IF_ERROR(CheckPositive("length_scale_m", length_scale_m));
  OAIPP_RETURN_IF_ERROR(CheckPositive("signal_var", signal_var));
  OAIPP_RETURN_IF_ERROR(CheckPositive("noise_var", noise_var));
  return CheckFinite("prior_mean", prior_mean);
}

absl::Status SensorNoise::Validate() const {
  OAIPP_RETURN_IF_ERROR(CheckPositive("a_var", a_var));
  return CheckPositive("b_per_m", b_per_m);
}

}  // namespace oaipp
