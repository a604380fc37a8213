#include "api/measurement.h"
#include "api/limits.h"

#include <map>
#include <optional>
#include <utility>

#include "absl/strings/str_cat.h"
#include "api/geometry.h"
#include "api/internal/checks.h"
#include "core/common/status_macros.h"

namespace oaipp::api {
namespace {

using internal::CheckFiniteVector;
using internal::CheckNonNegative;
using internal::CheckUnitInterval;
using internal::Prefixed;

absl::StatusOr<CellLabels> LabelsFromProto(const v1::CellLabels& in) {
  if (in.labels_size() != in.cells_size()) {
    return absl::InvalidArgumentError(absl::StrCat("labels.labels: has ", in.labels_size(),
                                                   " entries but labels.cells has ",
                                                   in.cells_size(), " (must match)"));
  }
  if (in.cells_size() > kMaxLabels) {
    return absl::InvalidArgumentError(
        absl::StrCat("labels.cells: ", in.cells_size(), " cells; at most ", kMaxLabels));
  }
  CellLabels out;
  out.cells.reserve(in.cells_size());
  out.labels.reserve(in.labels_size());
  std::map<int, int> first_index;
  for (int i = 0; i < in.cells_size(); ++i) {
    const int cell = in.cells(i);
    if (cell < 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("labels.cells[", i, "]: must be >= 0, got ", cell));
    }
    if (auto [it, inserted] = first_index.emplace(cell, i); !inserted) {
      return absl::InvalidArgumentError(absl::StrCat("labels.cells[", i, "]: cell ", cell,
                                                     " repeats labels.cells[", it->second, "]"));
    }
    OAIPP_RETURN_IF_ERROR(CheckUnitInterval(absl::StrCat("labels.labels[", i, "]"), in.labels(i)));
    out.cells.push_back(cell);
    out.labels.push_back(in.labels(i));
  }
  return out;
}

CameraIntrinsics IntrinsicsFromProto(const v1::CameraIntrinsics& k) {
  return {.fx_px = k.fx_px(),
          .fy_px = k.fy_px(),
          .cx_px = k.cx_px(),
          .cy_px = k.cy_px(),
          .width_px = k.width_px(),
          .height_px = k.height_px(),
          .k1 = k.k1(),
          .k2 = k.k2(),
          .p1 = k.p1(),
          .p2 = k.p2(),
          .k3 = k.k3()};
}

absl::StatusOr<MeasurementInput::Detections> DetectionsFromProto(const v1::ImageDetections& in) {
  MeasurementInput::Detections out;
  if (in.has_intrinsics()) {
    out.intrinsics = IntrinsicsFromProto(in.intrinsics());
    // CameraIntrinsics::Validate names its fields "intrinsics.<name>".
    OAIPP_RETURN_IF_ERROR(Prefixed("detections.", out.intrinsics->Validate()));
  }
  if (in.boxes_size() > kMaxBoxes) {
    return absl::InvalidArgumentError(absl::StrCat("detections.boxes: ", in.boxes_size(),
                                                   " boxes; at most ", kMaxBoxes, " per image"));
  }
  out.boxes.reserve(in.boxes_size());
  for (int i = 0; i < in.boxes_size(); ++i) {
    const v1::PixelBox& b = in.boxes(i);
    PixelBox box{.x_min_px = b.x_min_px(),
                 .y_min_px = b.y_min_px(),
                 .x_max_px = b.x_max_px(),
                 .y_max_px = b.y_max_px(),
                 .confidence = b.confidence()};
    OAIPP_RETURN_IF_ERROR(
        Prefixed(absl::StrCat("detections.boxes[", i, "]."),
                 box.Validate(out.intrinsics.has_value() ? &*out.intrinsics : nullptr)));
    out.boxes.push_back(box);
  }
  out.min_confidence = in.min_confidence();
  OAIPP_RETURN_IF_ERROR(CheckUnitInterval("detections.min_confidence", out.min_confidence));
  return out;
}

v1::CameraIntrinsics IntrinsicsToProto(const CameraIntrinsics& k) {
  v1::CameraIntrinsics out;
  out.set_fx_px(k.fx_px);
  out.set_fy_px(k.fy_px);
  out.set_cx_px(k.cx_px);
  out.set_cy_px(k.cy_px);
  out.set_width_px(k.width_px);
  out.set_height_px(k.height_px);
  out.set_k1(k.k1);
  out.set_k2(k.k2);
  out.set_p1(k.p1);
  out.set_p2(k.p2);
  out.set_k3(k.k3);
  return out;
}

}  // namespace

absl::StatusOr<MeasurementInput> MeasurementFromProto(const v1::AddMeasurementRequest& request) {
  MeasurementInput out;
  OAIPP_RETURN_IF_ERROR(CheckNonNegative("mission_time_s", request.mission_time_s()));
  out.mission_time_s = request.mission_time_s();
  out.uav_id = request.uav_id();  // checked against the mission's team by the mission
  OAIPP_RETURN_IF_ERROR(CheckFiniteVector("camera_position_m", request.camera_position_m()));
  if (!(request.camera_position_m().z() > 0.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("camera_position_m.z: must be above the ground (> 0), got ",
                     request.camera_position_m().z()));
  }
  OAIPP_RETURN_IF_ERROR(CheckFinite("camera_yaw_deg", request.camera_yaw_deg()));
  out.pose.p_WC = FromProto(request.camera_position_m());
  out.pose.yaw_rad = DegToRad(request.camera_yaw_deg());
  OAIPP_RETURN_IF_ERROR(out.pose.Validate());  // backstop; checked above

  switch (request.data_case()) {
    case v1::AddMeasurementRequest::kLabels: {
      OAIPP_ASSIGN_OR_RETURN(out.labels, LabelsFromProto(request.labels()));
      break;
    }
    case v1::AddMeasurementRequest::kDetections: {
      OAIPP_ASSIGN_OR_RETURN(out.detections, DetectionsFromProto(request.detections()));
      break;
    }
    case v1::AddMeasurementRequest::DATA_NOT_SET:
      return absl::InvalidArgumentError("data: must be set (labels or detections)");
  }
  return out;
}

void MeasurementToProto(const MeasurementInput& input, v1::AddMeasurementRequest* out) {
  out->set_mission_time_s(input.mission_time_s);
  *out->mutable_camera_position_m() = ToProto(input.pose.p_WC);
  out->set_camera_yaw_deg(input.pose.yaw_rad * 180.0 / kPi);
  out->set_uav_id(input.uav_id);
  out->clear_data();
  if (input.labels.has_value()) {
    v1::CellLabels& labels = *out->mutable_labels();
    labels.mutable_cells()->Assign(input.labels->cells.begin(), input.labels->cells.end());
    labels.mutable_labels()->Assign(input.labels->labels.begin(), input.labels->labels.end());
  } else if (input.detections.has_value()) {
    v1::ImageDetections& d = *out->mutable_detections();
    if (input.detections->intrinsics.has_value()) {
      *d.mutable_intrinsics() = IntrinsicsToProto(*input.detections->intrinsics);
    }
    d.set_min_confidence(input.detections->min_confidence);
    for (const PixelBox& b : input.detections->boxes) {
      v1::PixelBox& box = *d.add_boxes();
      box.set_x_min_px(b.x_min_px);
      box.set_y_min_px(b.y_min_px);
      box.set_x_max_px(b.x_max_px);
      box.set_y_max_px(b.y_max_px);
      box.set_confidence(b.confidence);
    }
  }
}

}  // namespace oaipp::api
