// A picture of a mission for people: the map's mean and standard deviation
// side by side (viridis, both on [0, 1], north up), with the obstacles'
// footprints (grey), the true targets (green boxes) and the flown path
// (red, white dot at the start; a team's in a colour per UAV) drawn over
// both.
//
//   OAIPP_ASSIGN_OR_RETURN(std::string png,
//                          RenderMissionPng(map, sim, {{"", path_W}}, "missions/m-000001", 42.0));
#pragma once

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "oaipp/v1/mission_service.pb.h"
#include "sim/simulation.h"

namespace oaipp::client {

// The path one UAV flew; uav_id is empty on a mission without a team.
struct FlownPath {
  std::string uav_id;
  std::vector<Vec3> points_W;
};

// `map` must carry its cells (GetMap with include_cells). InvalidArgument
// when it does not. One path without a uav_id is drawn red as "flown path";
// a team's paths each in its own colour (render::TeamColour), labelled with
// its uav_id.
[[nodiscard]] absl::StatusOr<std::string> RenderMissionPng(const v1::GetMapResponse& map,
                                                           const sim::Simulation& simulation,
                                                           const std::vector<FlownPath>& paths,
                                                           const std::string& mission_name,
                                                           double mission_time_s);

// Frames (PNG bytes, e.g. RenderMissionPng's) tiled `columns` wide, each
// scaled to the first one's width, with its caption written above it.
// InvalidArgument for no frames, a frame that does not decode, or a caption
// count that differs from the frame count.
[[nodiscard]] absl::StatusOr<std::string> MontagePng(const std::vector<std::string>& frames,
                                                     const std::vector<std::string>& captions,
                                                     int columns);

// The same captioned frames as a Motion-JPEG AVI video at `fps` frames per
// second, written to `path` with OpenCV's own MJPEG writer (no codec library
// needed to write or to play it back). Errors as MontagePng, InvalidArgument
// for fps not > 0, Internal when the file cannot be written.
[[nodiscard]] absl::Status WriteVideo(const std::vector<std::string>& frames,
                                      const std::vector<std::string>& captions, double fps,
                                      const std::string& path);

}  // namespace oaipp::client
