// proto <-> core for AddMeasurement: cell labels, or image detections with
// the camera pose and (optionally) intrinsics.
//
//   OAIPP_ASSIGN_OR_RETURN(MeasurementInput m, MeasurementFromProto(request));  // server
//   MeasurementToProto(m, &request);                                             // client
#pragma once

#include "absl/status/statusor.h"
#include "api/mission_config.h"
#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::api {

// One AddMeasurement request in core terms (camera yaw in radians). Checks
// what needs no mission: mission_time_s finite and >= 0, camera_position_m
// finite with z > 0, camera_yaw_deg finite; exactly one of labels and
// detections ("data: ..." when neither). Labels: as many labels as cells,
// cells >= 0 and distinct, labels finite in [0, 1] (kept in the order
// given). Detections: intrinsics (when set) valid, every box valid by
// PixelBox::Validate (inside the image when intrinsics are given),
// min_confidence in [0, 1]. Cells against the grid, the camera against the
// flight volume and boxes against the default image are the mission's
// checks. Failures are InvalidArgument naming the field
// ("labels.cells[4]", "detections.intrinsics.fx_px",
// "detections.boxes[1].x_max_px").
[[nodiscard]] absl::StatusOr<MeasurementInput> MeasurementFromProto(
    const v1::AddMeasurementRequest& request);

// The measurement fields of *out (time, camera pose, labels or
// detections) from `input`; the mission name and request_id are left alone.
// MeasurementFromProto gives `input` back (yaw to a few ulps).
void MeasurementToProto(const MeasurementInput& input, v1::AddMeasurementRequest* out);

}  // namespace oaipp::api
