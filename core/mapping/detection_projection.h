// From detector boxes in image pixels to ground cells (docs/method.md §4).
//
// A real ground station sends detections, not cell labels: boxes in the
// image of a downward camera with known pose and intrinsics. This module
// projects them to the field grid with OpenCV's pinhole + distortion model
// (k1, k2, p1, p2, k3) and turns one image into per-cell labels: 1 under a
// detection, 0 elsewhere in the visible image footprint.
//
// Camera frame C of a downward camera with yaw psi (rotation about world z):
//   z_C = -z_W (optical axis straight down),
//   x_C = Rz(psi) x_W (image u grows along world +x at yaw 0),
//   y_C = Rz(psi) (-y_W) (image v grows along world -y at yaw 0, so the
//         image is "north up": its top row sees the field's +y side).
// This is right-handed (x_C cross y_C = z_C). Pixel coordinates are
// continuous, the image covering [0, width_px] x [0, height_px] (so the
// principal point of a centred camera is (width_px / 2, height_px / 2)).
// The ground is the plane z = 0.
//
//   OAIPP_ASSIGN_OR_RETURN(CameraIntrinsics k, IntrinsicsForFov(640, 480));
//   CameraPose pose{.p_WC = Vec3(0, 0, 10), .yaw_rad = 0};
//   std::vector<PixelBox> boxes = {{.x_min_px = 300, .y_min_px = 220, .x_max_px = 340,
//                                   .y_max_px = 260, .confidence = 0.8}};
//   OAIPP_ASSIGN_OR_RETURN(CellLabels labels,
//                          DetectionsToLabels(grid, k, pose, boxes, /*min_confidence=*/0.05,
//                                             &environment));
//   OAIPP_ASSIGN_OR_RETURN(auto obs, LabelsToObservations(grid, SensorNoise{}, pose.p_WC.z(),
//                                                         labels.cells, labels.labels));
#pragma once

#include <span>
#include <vector>

#include "Eigen/Core"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/common/geometry.h"
#include "core/mapping/field_grid.h"

namespace oaipp {

// OpenCV camera intrinsics. Focal lengths and principal point in pixels.
struct CameraIntrinsics {
  // Valid: > 0, finite.
  double fx_px = 0.0;
  double fy_px = 0.0;
  // Valid: finite.
  double cx_px = 0.0;
  double cy_px = 0.0;
  // Image size. Valid: >= 1.
  int width_px = 0;
  int height_px = 0;
  // Distortion in OpenCV's order (k1, k2, p1, p2, k3). Valid: finite.
  double k1 = 0.0;
  double k2 = 0.0;
  double p1 = 0.0;
  double p2 = 0.0;
  double k3 = 0.0;

  // InvalidArgument naming the bad field ("intrinsics.fx_px: ...").
  [[nodiscard]] absl::Status Validate() const;
};

// Pose of a downward camera (frame convention in the file comment).
struct CameraPose {
  // Optical centre in W, metres. Valid: finite, z > 0 (above the ground).
  Vec3 p_WC = Vec3::Zero();
  // Yaw about world z, radians. Valid: finite.
  double yaw_rad = 0.0;

  // InvalidArgument naming the bad field ("pose.p_WC: ...").
  [[nodiscard]] absl::Status Validate() const;
};

// A detector's axis-aligned box in pixels.
struct PixelBox {
  // Valid: 0 <= x_min_px < x_max_px <= width_px, 0 <= y_min_px < y_max_px <= height_px.
  double x_min_px = 0.0;
  double y_min_px = 0.0;
  double x_max_px = 0.0;
  double y_max_px = 0.0;
  // Detector score. Valid: [0, 1].
  double confidence = 1.0;

  // The one rule for a box, used wherever boxes are made or read: corners
  // finite and >= 0, min < max, and inside the image when `image` is given;
  // confidence in [0, 1]. InvalidArgument naming the field ("x_max_px: ...").
  [[nodiscard]] absl::Status Validate(const CameraIntrinsics* image = nullptr) const;
};

// Cells of one image with their labels (1: detection, 0: none), sorted by cell.
struct CellLabels {
  std::vector<int> cells;
  std::vector<double> labels;
};

// R_WC: the camera axes x_C, y_C, z_C in world coordinates (columns).
[[nodiscard]] Eigen::Matrix3d RotationWorldFromCamera(double yaw_rad);

// Undistorted pinhole intrinsics whose full fields of view along the image
// width and height are fov_x_deg and fov_y_deg (the paper's camera is
// (45, 60) deg, docs/method.md §4), principal point at the image centre. At yaw
// 0 its image footprint matches DownwardCamera's footprint. InvalidArgument
// when a size is < 1 or a field of view is outside [kMinFovDeg, 180).
[[nodiscard]] absl::StatusOr<CameraIntrinsics> IntrinsicsForFov(int width_px, int height_px,
                                                                double fov_x_deg = 45.0,
                                                                double fov_y_deg = 60.0);

// The ground polygon (z = 0, metres) seen through `box`: its boundary sampled
// at samples_per_edge points per edge (so distortion's curved edges are
// followed), undistorted with cv::undistortPoints and intersected with the
// ground. Vertices in order around the box. InvalidArgument for invalid
// intrinsics, pose or box (named "box.x_min_px" etc.) or samples_per_edge < 1.
[[nodiscard]] absl::StatusOr<std::vector<Vec2>> GroundPolygon(const CameraIntrinsics& intrinsics,
                                                              const CameraPose& pose,
                                                              const PixelBox& box,
                                                              int samples_per_edge = 16);

// Cells whose square overlaps the ground polygon of a box with confidence
// >= min_confidence (FieldGrid::CellsOverlappingPolygon: the rule that
// rasterises ground-truth targets, so a box drawn tight around a person
// marks exactly that person's cells), and which the camera sees
// (line_of_sight to the cell centre; nullptr = no obstacles). The union over
// boxes, sorted. Under lens distortion the polygon follows each box edge at
// 16 points. InvalidArgument for invalid intrinsics, pose, boxes
// ("boxes[i].confidence") or min_confidence.
[[nodiscard]] absl::StatusOr<std::vector<int>> DetectionCells(
    const FieldGrid& grid, const CameraIntrinsics& intrinsics, const CameraPose& pose,
    std::span<const PixelBox> boxes, double min_confidence, const LineOfSight* line_of_sight);

// Cells whose centre projects inside the image (cv::projectPoints, the full
// distortion model) and which the camera sees. Sorted. InvalidArgument for
// invalid intrinsics or pose.
[[nodiscard]] absl::StatusOr<std::vector<int>> ImageFootprintCells(
    const FieldGrid& grid, const CameraIntrinsics& intrinsics, const CameraPose& pose,
    const LineOfSight* line_of_sight);

// One image as labels over ImageFootprintCells: 1 for a cell in
// DetectionCells (its square overlaps a confident box's ground polygon),
// else 0. Errors as DetectionCells.
[[nodiscard]] absl::StatusOr<CellLabels> DetectionsToLabels(
    const FieldGrid& grid, const CameraIntrinsics& intrinsics, const CameraPose& pose,
    std::span<const PixelBox> boxes, double min_confidence, const LineOfSight* line_of_sight);

}  // namespace oaipp
