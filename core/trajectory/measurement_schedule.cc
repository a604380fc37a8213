#include "core/trajectory/measurement_schedule.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/common/geometry.h"
#include "core/common/status_macros.h"

namespace oaipp {

absl::StatusOr<MeasurementSchedule> ScheduleMeasurements(const ShotWindow& window) {
  OAIPP_RETURN_IF_ERROR(
      CheckFinite("trajectory_start_mission_s", window.trajectory_start_mission_s));
  OAIPP_RETURN_IF_ERROR(CheckFinite("duration_s", window.duration_s));
  if (window.duration_s < 0.0) {
    return absl::InvalidArgumentError(
        absl::StrCat("duration_s: must be >= 0, got ", window.duration_s));
  }
  OAIPP_RETURN_IF_ERROR(CheckPositive("rate_hz", window.rate_hz));
  OAIPP_RETURN_IF_ERROR(CheckFinite("next_shot_mission_s", window.next_shot_mission_s));
  constexpr double kMaxShots = 1e7;
  const double period_s = 1.0 / window.rate_hz;
  const double start_s = window.trajectory_start_mission_s;
  const double end_s = start_s + window.duration_s;
  if ((end_s - std::min(window.next_shot_mission_s, start_s)) * window.rate_hz > kMaxShots) {
    return absl::InvalidArgumentError(absl::StrCat("rate_hz: ", window.rate_hz, " Hz over ",
                                                   end_s - start_s, " s exceeds ", kMaxShots,
                                                   " shots"));
  }

  double shot_s = window.next_shot_mission_s;
  // Shots missed before this trajectory (e.g. between a plan and its start)
  // are skipped, not fired late, so the phase is unchanged.
  while (shot_s < start_s) shot_s += period_s;
  MeasurementSchedule schedule;
  for (; shot_s < end_s; shot_s += period_s) schedule.times_s.push_back(shot_s - start_s);
  schedule.next_shot_mission_s = shot_s;
  return schedule;
}

}  // namespace oaipp
