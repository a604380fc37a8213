// What `oaipp-client export` writes for one UAV's exported path: the
// QGroundControl .plan, the MAVLink mission items (MAVSDK MissionRaw
// fields) and the NED offboard setpoints, in one folder.
//
//   OAIPP_RETURN_IF_ERROR(WriteExportFiles("out/export/e5/uav-1", exported));
#pragma once

#include <string>

#include "absl/status/status.h"
#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::client {

// Writes dir/mission.plan, dir/mission_items.csv and dir/setpoints.csv,
// creating dir. Internal when a file cannot be written.
[[nodiscard]] absl::Status WriteExportFiles(const std::string& dir,
                                            const v1::ExportPathResponse& exported);

}  // namespace oaipp::client
