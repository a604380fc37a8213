#include "core/mapping/camera.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"

namespace oaipp {

absl::Status CheckFovDeg(absl::string_view field, double fov_deg) {
  if (fov_deg >= kMinFovDeg && fov_deg < 180.0) return absl::OkStatus();  // false for NaN
  return absl::InvalidArgumentError(
      absl::StrCat(field, ": must be in [", kMinFovDeg, ", 180) degrees, got ", fov_deg));
}

absl::Status DownwardCamera::Validate() const {
  OAIPP_RETURN_IF_ERROR(CheckFovDeg("fov_x_deg", fov_x_deg));
  OAIPP_RETURN_IF_ERROR(CheckFovDeg("fov_y_deg", fov_y_deg));
  return CheckPositive("rate_hz", rate_hz);
}

Vec2 DownwardCamera::FootprintSize(double altitude_m) const {
  if (!(altitude_m > 0.0)) return Vec2::Zero();
  return 2.0 * altitude_m *
         Vec2(std::tan(0.5 * DegToRad(fov_x_deg)), std::tan(0.5 * DegToRad(fov_y_deg)));
}

std::vector<int> DownwardCamera::FootprintCells(const FieldGrid& grid, const Vec3& p_WC,
                                                double yaw_rad) const {
  if (!AllFinite(p_WC) || !(p_WC.z() > 0.0)) return {};
  return grid.CellsInRectangle(p_WC.head<2>(), FootprintSize(p_WC.z()), yaw_rad);
}

std::vector<int> DownwardCamera::VisibleFootprintCells(const FieldGrid& grid, const Vec3& p_WC,
                                                       const LineOfSight* line_of_sight,
                                                       double yaw_rad) const {
  std::vector<int> cells = FootprintCells(grid, p_WC, yaw_rad);
  if (line_of_sight == nullptr) return cells;
  std::erase_if(cells,
                [&](int cell) { return !line_of_sight->IsVisible(p_WC, grid.CellCentre(cell)); });
  return cells;
}

absl::StatusOr<std::vector<CellObservation>> LabelsToObservations(const FieldGrid& grid,
                                                                  const SensorNoise& noise,
                                                                  double altitude_m,
                                                                  std::span<const int> cells,
                                                                  std::span<const double> labels) {
  OAIPP_RETURN_IF_ERROR(CheckPositive("altitude_m", altitude_m));
  OAIPP_RETURN_IF_ERROR(noise.Validate());
  if (cells.size() != labels.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("labels: ", labels.size(), " labels for ", cells.size(), " cells"));
  }
  // A detector with a false-positive rate weighs its two labels differently
  // (DetectorAccuracy::LabelVariance); otherwise both are the same.
  const double miss_variance = noise.LabelVariance(altitude_m, 0.0);
  const double detection_variance = noise.LabelVariance(altitude_m, 1.0);
  for (const double variance : {miss_variance, detection_variance}) {
    if (!(variance > 0.0)) {
      return absl::InvalidArgumentError(
          absl::StrCat("altitude_m: var(", altitude_m, ") = ", variance, " is not positive"));
    }
  }
  std::vector<CellObservation> obs;
  obs.reserve(cells.size());
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (!grid.IsValidCell(cells[i])) {
      return absl::InvalidArgumentError(
          absl::StrCat("cells[", i, "]: ", cells[i], " is outside [0, ", grid.num_cells(), ")"));
    }
    if (!(labels[i] >= 0.0 && labels[i] <= 1.0)) {
      return absl::InvalidArgumentError(
          absl::StrCat("labels[", i, "]: must be in [0, 1], got ", labels[i]));
    }
    obs.push_back({.cell = cells[i],
                   .value = labels[i],
                   .variance = labels[i] >= kDetectedLabel ? detection_variance : miss_variance});
  }
  return obs;
}

std::vector<CellObservation> PredictedObservations(const SensorNoise& noise, double altitude_m,
                                                   std::span<const int> cells) {
  const double variance = noise.Variance(altitude_m);
  std::vector<CellObservation> obs;
  obs.reserve(cells.size());
  for (int cell : cells) obs.push_back({.cell = cell, .value = 0.0, .variance = variance});
  return obs;
}

}  // namespace oaipp
