// Messages shared by the fuzz targets and the seed writer: the fixed small
// mission that fuzz_requests applies measurements and obstacle changes to,
// and the vector and obstacle helpers that build requests for it.
#pragma once

#include <string>

#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::fuzz {

[[nodiscard]] v1::Vector3 V(double x, double y, double z);

// A box obstacle `id` at `centre` with `size`, turned by `yaw_deg`.
[[nodiscard]] v1::Obstacle BoxObstacle(const std::string& id, const v1::Vector3& centre,
                                       const v1::Vector3& size, double yaw_deg);

// The fixed mission: a 10 x 10 m field at 1 m cells (100 cells), flight
// between 2 and 12 m, 0.5 m ESDF voxels, a turned box "tower" at (2, -1)
// and a cylinder "mast" at (-3, 3); no start (the default one).
[[nodiscard]] v1::MissionSpec FixedMissionSpec();

}  // namespace oaipp::fuzz
