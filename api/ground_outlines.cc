#include "api/ground_outlines.h"

namespace oaipp::api {

GroundOutlines GroundOutlinesOf(const MissionConfig& config,
                                const std::vector<Obstacle>& obstacles) {
  GroundOutlines out;
  for (const Obstacle& o : obstacles) out.obstacle_footprints.push_back(GroundFootprint(o.shape));
  if (config.search_area != nullptr) out.search_area_rings = config.search_area->Rings();
  if (const std::optional<Fence>& fence = config.airspace.fence(); fence.has_value()) {
    out.fence_rings = {config.airspace.FenceOutline()};
  }
  out.no_fly_footprints = config.airspace.ZoneFootprints();
  if (config.planner.home.has_value()) out.home = config.planner.home->home_W.head<2>();
  return out;
}

}  // namespace oaipp::api
