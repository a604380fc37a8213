// What the fuzz targets and the seed writer share: fuzz_requests' message
// types, the fixed small mission it applies measurements and obstacle
// changes to, and the vector and obstacle helpers that build requests.
#pragma once

#include <cstdint>
#include <string>

#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::fuzz {

// fuzz_requests' message types: byte 0 of an input, modulo kNumKinds. New
// kinds go at the end, so that the committed corpus keeps its meaning.
enum class MessageKind : std::uint8_t {
  kCreateMission = 0,
  kGetMission = 1,
  kListMissions = 2,
  kDeleteMission = 3,
  kUpdateObstacles = 4,
  kAddMeasurement = 5,
  kPlanPath = 6,
  kGetMap = 7,
  kWatchMission = 8,
  // Not a request: the server reads its stored first answers back with
  // api::PlannedPathFromProto (server/registry.cc, store/state_codec.cc).
  kPlanPathResponse = 9,
  kExportPath = 10,
};
inline constexpr int kNumKinds = 11;

[[nodiscard]] v1::Vector3 V(double x, double y, double z);

// A box obstacle `id` at `centre` with `size`, turned by `yaw_deg`.
[[nodiscard]] v1::Obstacle BoxObstacle(const std::string& id, const v1::Vector3& centre,
                                       const v1::Vector3& size, double yaw_deg);

// The fixed mission: a 10 x 10 m field at 1 m cells (100 cells), flight
// between 2 and 12 m, 0.5 m ESDF voxels, a turned box "tower" at (2, -1)
// and a cylinder "mast" at (-3, 3); no start (the default one).
[[nodiscard]] v1::MissionSpec FixedMissionSpec();

}  // namespace oaipp::fuzz
