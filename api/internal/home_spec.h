// MissionSpec.home <-> MissionConfig::planner.home
// (core/planning/return_home.h): read and validated with the API's field
// names, and written back.
#pragma once

#include "absl/status/status.h"
#include "api/mission_config.h"
#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::api::internal {

// Fills c.planner.home from spec.home (metres only: ResolveGeoFields has
// converted WGS84). Reads c's flight volume, budget and team, so it runs
// after those are filled. InvalidArgument naming the field
// ("spec.home.position_m", "spec.home.reserve_s", ...) for a missing or
// non-finite position, one outside the flight volume, a reserve outside
// [0, budget_s), a landing speed that is not positive, or a home with a
// team. What needs the obstacles (clearance, the column down, a way from
// the start) the server checks when it builds the world.
[[nodiscard]] absl::Status FillHome(const v1::MissionSpec& spec, MissionConfig& c);

// Writes c.planner.home (if any) into spec->home, in metres.
void WriteHome(const MissionConfig& c, v1::MissionSpec* spec);

}  // namespace oaipp::api::internal
