#include "core/mapping/detection_projection.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"
#include "core/mapping/camera.h"
#include "opencv2/calib3d.hpp"
#include "opencv2/core.hpp"

namespace oaipp {
namespace {

// Projected cell centres this close outside the image (pixels) still count
// as inside, so that a centre exactly on the image edge does not flicker.
constexpr double kPixelTolerance = 1e-9;

absl::Status ValidateCommon(const CameraIntrinsics& intrinsics, const CameraPose& pose) {
  OAIPP_RETURN_IF_ERROR(intrinsics.Validate());
  return pose.Validate();
}

absl::Status ValidateBoxes(std::span<const PixelBox> boxes, const CameraIntrinsics& intrinsics,
                           double min_confidence) {
  if (!(min_confidence >= 0.0 && min_confidence <= 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("min_confidence: must be in [0, 1], got ", min_confidence));
  }
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    if (absl::Status status = boxes[i].Validate(&intrinsics); !status.ok()) {
      return absl::Status(status.code(), absl::StrCat("boxes[", i, "].", status.message()));
    }
  }
  return absl::OkStatus();
}

cv::Matx33d CameraMatrix(const CameraIntrinsics& k) {
  return {k.fx_px, 0.0, k.cx_px, 0.0, k.fy_px, k.cy_px, 0.0, 0.0, 1.0};
}

cv::Vec<double, 5> Distortion(const CameraIntrinsics& k) { return {k.k1, k.k2, k.p1, k.p2, k.k3}; }

// Ground points (z = 0) seen at the given pixels: undistort to normalised
// coordinates, then follow the ray d_C = (x_n, y_n, 1) from p_WC. Since
// z_C = -z_W every such ray descends one metre per unit of t, so it meets the
// ground at t = altitude.
std::vector<Vec2> PixelsToGround(const std::vector<cv::Point2d>& pixels,
                                 const CameraIntrinsics& intrinsics, const CameraPose& pose) {
  std::vector<cv::Point2d> normalised;
  // The default 5 iterations leave visible error under strong distortion.
  cv::undistortPoints(
      pixels, normalised, CameraMatrix(intrinsics), Distortion(intrinsics), cv::noArray(),
      cv::noArray(), cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-10));
  const Eigen::Matrix3d r_WC = RotationWorldFromCamera(pose.yaw_rad);
  std::vector<Vec2> ground;
  ground.reserve(normalised.size());
  for (const cv::Point2d& q : normalised) {
    const Vec3 d_W = r_WC * Vec3(q.x, q.y, 1.0);
    ground.push_back((pose.p_WC + pose.p_WC.z() * d_W).head<2>());
  }
  return ground;
}

// Boundary of a pixel rectangle, counter-clockwise in pixels, n points per edge.
std::vector<cv::Point2d> SampleBoundary(double x0, double y0, double x1, double y1, int n) {
  const cv::Point2d corners[4] = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
  std::vector<cv::Point2d> points;
  points.reserve(4 * static_cast<std::size_t>(n));
  for (int e = 0; e < 4; ++e) {
    const cv::Point2d& a = corners[e];
    const cv::Point2d& b = corners[(e + 1) % 4];
    for (int i = 0; i < n; ++i) points.push_back(a + (b - a) * (static_cast<double>(i) / n));
  }
  return points;
}

std::vector<Vec2> GroundPolygonUnchecked(const CameraIntrinsics& intrinsics, const CameraPose& pose,
                                         double x0, double y0, double x1, double y1,
                                         int samples_per_edge) {
  return PixelsToGround(SampleBoundary(x0, y0, x1, y1, samples_per_edge), intrinsics, pose);
}

void KeepVisible(const FieldGrid& grid, const Vec3& p_WC, const LineOfSight* line_of_sight,
                 std::vector<int>& cells) {
  if (line_of_sight == nullptr) return;
  std::erase_if(cells,
                [&](int cell) { return !line_of_sight->IsVisible(p_WC, grid.CellCentre(cell)); });
}

// Cells overlapped by the ground polygon of a box with confidence >=
// min_confidence, unioned over the boxes; sorted. Occlusion is not applied.
std::vector<int> BoxCells(const FieldGrid& grid, const CameraIntrinsics& intrinsics,
                          const CameraPose& pose, std::span<const PixelBox> boxes,
                          double min_confidence) {
  std::vector<int> cells;
  for (const PixelBox& b : boxes) {
    if (b.confidence < min_confidence) continue;
    const std::vector<Vec2> polygon = GroundPolygonUnchecked(
        intrinsics, pose, b.x_min_px, b.y_min_px, b.x_max_px, b.y_max_px, 16);
    const std::vector<int> overlapped = grid.CellsOverlappingPolygon(polygon);
    std::vector<int> merged;
    merged.reserve(cells.size() + overlapped.size());
    std::set_union(cells.begin(), cells.end(), overlapped.begin(), overlapped.end(),
                   std::back_inserter(merged));
    cells = std::move(merged);
  }
  return cells;
}

// Image footprint cells: those whose centre projects into the image and is
// seen. Sorted.
std::vector<int> ProjectFootprint(const FieldGrid& grid, const CameraIntrinsics& intrinsics,
                                  const CameraPose& pose, const LineOfSight* line_of_sight) {
  // Candidates: the bounding box of the image's ground polygon grown by a
  // cell. Only these are projected: far outside the field of view the
  // distortion polynomial can fold back and map points into the image.
  const std::vector<Vec2> image_polygon =
      GroundPolygonUnchecked(intrinsics, pose, 0.0, 0.0, intrinsics.width_px, intrinsics.height_px,
                             /*samples_per_edge=*/16);
  Vec2 lo = image_polygon[0];
  Vec2 hi = image_polygon[0];
  for (const Vec2& v : image_polygon) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const double r = grid.resolution_m();
  std::vector<int> out;
  const std::vector<int> candidates =
      grid.CellsInRectangle(0.5 * (lo + hi), (hi - lo).array() + 2.0 * r, 0.0);
  if (candidates.empty()) return out;

  // World -> camera for OpenCV: p_C = R_CW p_W + t, R_CW = R_WC^T, t = -R_CW p_WC.
  const Eigen::Matrix3d r_CW = RotationWorldFromCamera(pose.yaw_rad).transpose();
  const Vec3 t_C = -r_CW * pose.p_WC;
  cv::Matx33d r_cv;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r_cv(i, j) = r_CW(i, j);
  }
  cv::Vec3d rvec;
  cv::Rodrigues(r_cv, rvec);
  const cv::Vec3d tvec(t_C.x(), t_C.y(), t_C.z());
  std::vector<cv::Point3d> centres;
  centres.reserve(candidates.size());
  for (int cell : candidates) {
    const Vec2 c = grid.CellCentreXY(cell);
    centres.emplace_back(c.x(), c.y(), 0.0);
  }
  std::vector<cv::Point2d> pixels;
  cv::projectPoints(centres, rvec, tvec, CameraMatrix(intrinsics), Distortion(intrinsics), pixels);
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const cv::Point2d& p = pixels[i];
    if (p.x >= -kPixelTolerance && p.x <= intrinsics.width_px + kPixelTolerance &&
        p.y >= -kPixelTolerance && p.y <= intrinsics.height_px + kPixelTolerance &&
        (line_of_sight == nullptr ||
         line_of_sight->IsVisible(pose.p_WC, grid.CellCentre(candidates[i])))) {
      out.push_back(candidates[i]);
    }
  }
  return out;
}

}  // namespace

absl::Status PixelBox::Validate(const CameraIntrinsics* image) const {
  const double inf = std::numeric_limits<double>::infinity();
  const double w = image != nullptr ? image->width_px : inf;
  const double h = image != nullptr ? image->height_px : inf;
  const struct {
    const char* field;
    double value;
    double hi;
  } coords[] = {{"x_min_px", x_min_px, w},
                {"y_min_px", y_min_px, h},
                {"x_max_px", x_max_px, w},
                {"y_max_px", y_max_px, h}};
  for (const auto& c : coords) {
    if (std::isfinite(c.value) && c.value >= 0.0 && c.value <= c.hi) continue;
    if (image == nullptr) {
      return absl::InvalidArgumentError(
          absl::StrCat(c.field, ": must be >= 0 and finite, got ", c.value));
    }
    return absl::InvalidArgumentError(
        absl::StrCat(c.field, ": must be in [0, ", c.hi, "] (inside the image), got ", c.value));
  }
  if (!(x_min_px < x_max_px)) {
    return absl::InvalidArgumentError(
        absl::StrCat("x_max_px: must exceed x_min_px (", x_min_px, "), got ", x_max_px));
  }
  if (!(y_min_px < y_max_px)) {
    return absl::InvalidArgumentError(
        absl::StrCat("y_max_px: must exceed y_min_px (", y_min_px, "), got ", y_max_px));
  }
  if (!(confidence >= 0.0 && confidence <= 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("confidence: must be in [0, 1], got ", confidence));
  }
  return absl::OkStatus();
}

absl::Status CameraIntrinsics::Validate() const {
  OAIPP_RETURN_IF_ERROR(CheckPositive("intrinsics.fx_px", fx_px));
  OAIPP_RETURN_IF_ERROR(CheckPositive("intrinsics.fy_px", fy_px));
  OAIPP_RETURN_IF_ERROR(CheckFinite("intrinsics.cx_px", cx_px));
  OAIPP_RETURN_IF_ERROR(CheckFinite("intrinsics.cy_px", cy_px));
  if (width_px < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("intrinsics.width_px: must be >= 1, got ", width_px));
  }
  if (height_px < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("intrinsics.height_px: must be >= 1, got ", height_px));
  }
  OAIPP_RETURN_IF_ERROR(CheckFinite("intrinsics.k1", k1));
  OAIPP_RETURN_IF_ERROR(CheckFinite("intrinsics.k2", k2));
  OAIPP_RETURN_IF_ERROR(CheckFinite("intrinsics.p1", p1));
  OAIPP_RETURN_IF_ERROR(CheckFinite("intrinsics.p2", p2));
  return CheckFinite("intrinsics.k3", k3);
}

absl::Status CameraPose::Validate() const {
  OAIPP_RETURN_IF_ERROR(CheckFinite("pose.p_WC", p_WC));
  if (!(p_WC.z() > 0.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("pose.p_WC.z: must be above the ground (> 0), got ", p_WC.z()));
  }
  return CheckFinite("pose.yaw_rad", yaw_rad);
}

Eigen::Matrix3d RotationWorldFromCamera(double yaw_rad) {
  const double c = std::cos(yaw_rad);
  const double s = std::sin(yaw_rad);
  Eigen::Matrix3d r_WC;
  // Columns: x_C = Rz x_W, y_C = Rz (-y_W), z_C = -z_W.
  r_WC << c, s, 0.0,  //
      s, -c, 0.0,     //
      0.0, 0.0, -1.0;
  return r_WC;
}

absl::StatusOr<CameraIntrinsics> IntrinsicsForFov(int width_px, int height_px, double fov_x_deg,
                                                  double fov_y_deg) {
  if (width_px < 1) {
    return absl::InvalidArgumentError(absl::StrCat("width_px: must be >= 1, got ", width_px));
  }
  if (height_px < 1) {
    return absl::InvalidArgumentError(absl::StrCat("height_px: must be >= 1, got ", height_px));
  }
  OAIPP_RETURN_IF_ERROR(CheckFovDeg("fov_x_deg", fov_x_deg));
  OAIPP_RETURN_IF_ERROR(CheckFovDeg("fov_y_deg", fov_y_deg));
  // The image edge at u = width sees the ray at fov_x / 2 off the axis.
  return CameraIntrinsics{.fx_px = 0.5 * width_px / std::tan(0.5 * DegToRad(fov_x_deg)),
                          .fy_px = 0.5 * height_px / std::tan(0.5 * DegToRad(fov_y_deg)),
                          .cx_px = 0.5 * width_px,
                          .cy_px = 0.5 * height_px,
                          .width_px = width_px,
                          .height_px = height_px};
}

absl::StatusOr<std::vector<Vec2>> GroundPolygon(const CameraIntrinsics& intrinsics,
                                                const CameraPose& pose, const PixelBox& box,
                                                int samples_per_edge) {
  OAIPP_RETURN_IF_ERROR(ValidateCommon(intrinsics, pose));
  if (absl::Status status = box.Validate(&intrinsics); !status.ok()) {
    return absl::Status(status.code(), absl::StrCat("box.", status.message()));
  }
  if (samples_per_edge < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("samples_per_edge: must be >= 1, got ", samples_per_edge));
  }
  return GroundPolygonUnchecked(intrinsics, pose, box.x_min_px, box.y_min_px, box.x_max_px,
                                box.y_max_px, samples_per_edge);
}

absl::StatusOr<std::vector<int>> DetectionCells(
    const FieldGrid& grid, const CameraIntrinsics& intrinsics, const CameraPose& pose,
    std::span<const PixelBox> boxes, double min_confidence, const LineOfSight* line_of_sight) {
  OAIPP_RETURN_IF_ERROR(ValidateCommon(intrinsics, pose));
  OAIPP_RETURN_IF_ERROR(ValidateBoxes(boxes, intrinsics, min_confidence));
  std::vector<int> cells = BoxCells(grid, intrinsics, pose, boxes, min_confidence);
  KeepVisible(grid, pose.p_WC, line_of_sight, cells);
  return cells;
}

absl::StatusOr<std::vector<int>> ImageFootprintCells(const FieldGrid& grid,
                                                     const CameraIntrinsics& intrinsics,
                                                     const CameraPose& pose,
                                                     const LineOfSight* line_of_sight) {
  OAIPP_RETURN_IF_ERROR(ValidateCommon(intrinsics, pose));
  return ProjectFootprint(grid, intrinsics, pose, line_of_sight);
}

absl::StatusOr<CellLabels> DetectionsToLabels(
    const FieldGrid& grid, const CameraIntrinsics& intrinsics, const CameraPose& pose,
    std::span<const PixelBox> boxes, double min_confidence, const LineOfSight* line_of_sight) {
  OAIPP_RETURN_IF_ERROR(ValidateCommon(intrinsics, pose));
  OAIPP_RETURN_IF_ERROR(ValidateBoxes(boxes, intrinsics, min_confidence));
  const std::vector<int> detected = BoxCells(grid, intrinsics, pose, boxes, min_confidence);
  CellLabels out;
  out.cells = ProjectFootprint(grid, intrinsics, pose, line_of_sight);
  out.labels.reserve(out.cells.size());
  for (int cell : out.cells) {
    out.labels.push_back(std::binary_search(detected.begin(), detected.end(), cell) ? 1.0 : 0.0);
  }
  return out;
}

}  // namespace oaipp
