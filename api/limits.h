// Upper bounds on what one request may ask for, so that a request's cost in
// memory and time is known before anything is allocated. Every conversion in
// api/ enforces them (InvalidArgument naming the field and the bound);
// docs/limits.md lists them with the reasons.
#pragma once

#include <cstdint>

namespace oaipp::api {

// CMA-ES population (lambda) and generations of one plan.
inline constexpr int kMaxPopulation = 10'000;
inline constexpr int kMaxGenerations = 100'000;
// Control waypoints of one plan.
inline constexpr int kMaxWaypoints = 20;
// Obstacles of one mission, and of one UpdateObstacles change.
inline constexpr int kMaxObstacles = 1'000;
// UAVs in a mission's team (MissionSpec.team), and the length of a uav_id.
inline constexpr int kMaxTeam = 16;
inline constexpr int kMaxUavIdBytes = 32;
// Detection boxes of one image, and labelled cells of one measurement.
inline constexpr int kMaxBoxes = 1'000;
inline constexpr int kMaxLabels = 65'536;
// Obstacle coordinates and sizes, metres: 1000 km, far past any field, so
// that every obstacle maps to voxel indices an int can hold.
inline constexpr double kMaxCoordinateM = 1e6;
// request_id of a mutation, a plan, a create or a delete, bytes: as long
// as an id (a UUID takes 36). Every remembered answer holds a copy or two,
// and the mission's log one more.
inline constexpr int kMaxRequestIdBytes = 128;
// A prior map's values in label units (GpSpec.prior_map): a label is 0 or
// 1, so a prior mean past this says the units are wrong.
inline constexpr double kMaxPriorMapValue = 1e6;
// One gRPC message, either way (a 4096-cell GetMap with cells is 0.2 MB).
inline constexpr std::int64_t kMaxMessageBytes = 16 << 20;

}  // namespace oaipp::api
