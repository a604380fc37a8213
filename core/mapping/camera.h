// The downward camera as the map sees it: which cells a measurement covers
// and with what noise (docs/method.md §4, §2.5).
//
// The camera looks straight down from p_WC. With field of view
// (fov_x_deg, fov_y_deg) = (45, 60) its footprint at altitude h is the
// rectangle 2 h tan(22.5 deg) x 2 h tan(30 deg) centred under it, the first
// side along the camera's x axis (world x at yaw 0). A cell is in the
// footprint when its centre is; it is visible when the segment from the
// camera to its centre meets no obstacle (LineOfSight). A measurement turns
// labels of visible cells into CellObservations with variance var(h).
//
//   DownwardCamera camera;                                  // (45, 60) deg
//   Vec2 size_m = camera.FootprintSize(/*altitude_m=*/10);  // 8.28 x 11.55 m
//   std::vector<int> cells = camera.VisibleFootprintCells(grid, p_WC, &environment);
//   OAIPP_ASSIGN_OR_RETURN(std::vector<CellObservation> obs,
//                          LabelsToObservations(grid, SensorNoise{}, p_WC.z(), cells, labels));
//   OAIPP_RETURN_IF_ERROR(map.Update(obs));
#pragma once

#include <span>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/common/geometry.h"
#include "core/mapping/field_grid.h"
#include "core/mapping/gp_map.h"
#include "core/mapping/gp_params.h"

namespace oaipp {

// Narrowest field of view a camera may have, degrees. Far below it the
// focal length that a field of view gives an image overflows to infinity;
// no real lens comes near it.
inline constexpr double kMinFovDeg = 0.1;

// OK when fov_deg is in [kMinFovDeg, 180); else InvalidArgument naming
// `field`.
[[nodiscard]] absl::Status CheckFovDeg(absl::string_view field, double fov_deg);

struct DownwardCamera {
  // Full field of view along the camera's x axis (world x at yaw 0), degrees.
  // Valid: [kMinFovDeg, 180).
  double fov_x_deg = 45.0;
  // Full field of view along the camera's y axis (world y at yaw 0), degrees.
  // Valid: [kMinFovDeg, 180).
  double fov_y_deg = 60.0;
  // Shots per second on the mission clock (0.15 in the paper). Valid: > 0.
  double rate_hz = 0.15;

  // InvalidArgument naming the bad field.
  [[nodiscard]] absl::Status Validate() const;

  // Edge lengths (along camera x, camera y) of the ground footprint from
  // altitude_m: 2 h tan(fov / 2). Zero for altitude_m <= 0.
  [[nodiscard]] Vec2 FootprintSize(double altitude_m) const;

  // Cells whose centre lies in the footprint of a camera at p_WC (altitude
  // p_WC.z() above the ground z = 0) with yaw yaw_rad about world z. Sorted
  // by index; empty when p_WC.z() <= 0 or p_WC is not finite.
  [[nodiscard]] std::vector<int> FootprintCells(const FieldGrid& grid, const Vec3& p_WC,
                                                double yaw_rad = 0.0) const;

  // The footprint cells whose centre the camera sees: line_of_sight->IsVisible(
  // p_WC, centre) for each; nullptr means an empty world (every cell seen).
  [[nodiscard]] std::vector<int> VisibleFootprintCells(const FieldGrid& grid, const Vec3& p_WC,
                                                       const LineOfSight* line_of_sight,
                                                       double yaw_rad = 0.0) const;
};

// One measurement's observations: labels[i] of cells[i], each with variance
// noise.LabelVariance(altitude_m, labels[i]), the same for every label
// except with a detector's false-positive rate (docs/method.md §3). InvalidArgument naming the
// field when altitude_m is not positive and finite, noise is invalid, the
// spans differ in size, a cell is out of range or a label is not in [0, 1].
// Which cells to pass (typically VisibleFootprintCells) is the caller's
// choice; repeated cells are merged by GpMap::Update.
[[nodiscard]] absl::StatusOr<std::vector<CellObservation>> LabelsToObservations(
    const FieldGrid& grid, const SensorNoise& noise, double altitude_m, std::span<const int> cells,
    std::span<const double> labels);

// Hypothetical observations of `cells` from altitude_m, for planning (the
// covariance update ignores values, so they are 0), with
// noise.Variance(altitude_m), a miss's variance when labels differ. Preconditions as
// LabelsToObservations; no validation (planning hot path).
[[nodiscard]] std::vector<CellObservation> PredictedObservations(const SensorNoise& noise,
                                                                 double altitude_m,
                                                                 std::span<const int> cells);

}  // namespace oaipp
