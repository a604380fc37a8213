// A mission's world as pictures draw it (core/common/ground_outlines.h):
// one place for the server's GetMap picture, its live view and the
// client's map picture.
//
//   render::Overlay overlay(api::GroundOutlinesOf(config, obstacles));
#pragma once

#include <vector>

#include "api/mission_config.h"
#include "core/common/ground_outlines.h"
#include "core/environment/obstacle.h"

namespace oaipp::api {

// The footprints of `obstacles` (the mission's current ones, which updates
// may have changed since config.obstacles), the search area's rings, the
// fence's outline (a circle as a 64-gon), the zones' footprints and the
// home.
[[nodiscard]] GroundOutlines GroundOutlinesOf(const MissionConfig& config,
                                              const std::vector<Obstacle>& obstacles);

}  // namespace oaipp::api
