// A mission described in core terms: what CreateMission's spec becomes once
// defaults are filled in and every field is validated (server/convert.h does
// that). Nothing here knows about protobuf.
//
//   OAIPP_ASSIGN_OR_RETURN(MissionConfig config, MissionSpecToConfig(request.spec()));
//   Aabb volume = config.FlightVolume();
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/environment/environment.h"
#include "core/mapping/camera.h"
#include "core/mapping/detection_projection.h"
#include "core/mapping/gp_params.h"
#include "core/planning/planners.h"

namespace oaipp::server {

struct MissionConfig {
  std::string preset;  // "" or "paper"
  // Field rectangle on the ground and its cells.
  Vec2 field_min_W = Vec2(-15, -15);
  Vec2 field_max_W = Vec2(15, 15);
  double resolution_m = 0.75;
  GpParams gp = GpParams::PaperPreset(0.75);
  DownwardCamera camera;
  SensorNoise noise;
  // Flight altitudes over the field.
  double min_altitude_m = 2.0;
  double max_altitude_m = 26.0;
  EsdfConfig esdf;
  // The planner; planner.common.limits holds speed, acceleration, r_uav and
  // the sensor rate.
  PlannerConfig planner;
  std::vector<Obstacle> obstacles;
  UavState start;
  double budget_s = 150.0;

  [[nodiscard]] Aabb FlightVolume() const {
    return {{field_min_W.x(), field_min_W.y(), min_altitude_m},
            {field_max_W.x(), field_max_W.y(), max_altitude_m}};
  }
  [[nodiscard]] double sensor_rate_hz() const { return planner.common.limits.sensor_rate_hz; }
};

// One camera measurement from AddMeasurement, in core terms.
struct MeasurementInput {
  double mission_time_s = 0.0;
  CameraPose pose;  // camera position and yaw (radians)
  // Exactly one of the two is set.
  std::optional<CellLabels> labels;
  struct Detections {
    std::optional<CameraIntrinsics> intrinsics;  // unset: from the mission's FoV
    std::vector<PixelBox> boxes;
    double min_confidence = 0.0;
  };
  std::optional<Detections> detections;
};

}  // namespace oaipp::server
