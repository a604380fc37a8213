#include "server/registry_limits.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/environment/esdf.h"
#include "core/environment/obstacle.h"

namespace oaipp::server {

MemoryEstimate EstimateMissionBytes(const api::MissionConfig& config) {
  MemoryEstimate e;
  const double cells = config.CellCount();
  if (config.ResolveMapBackend() == api::MapBackend::kSparse) {
    // The sparse map's factor grows as n log n: 4.1 KB a cell were measured
    // at 90,000 cells and 4.6 KB at 250,000 (docs/benchmarks.md); this
    // counts about 30 % more, and the planner's dense window of 41 x 41
    // cells (its covariance and the objective's copies).
    e.map_bytes = static_cast<std::int64_t>(330.0 * cells * std::log2(std::max(2.0, cells)) + 64e6);
  } else {
    // The map and a plan's conditioned copy; a team's plans keep one more
    // between them (ConditioningChain).
    const double copies = config.team.size() >= 2 ? 3.0 : 2.0;
    e.map_bytes = static_cast<std::int64_t>(copies * 8.0 * cells * (cells + 1.0));
  }
  // The ESDF: 4 bytes a voxel held (its block table, and the blocks within
  // reach of an obstacle's surface).
  std::vector<const Shape*> shapes;
  shapes.reserve(config.obstacles.size());
  for (const Obstacle& o : config.obstacles) shapes.push_back(&o.shape);
  const double voxels =
      static_cast<double>(Esdf::HeldVoxelBound(config.FlightVolume(), config.esdf, shapes));
  e.esdf_bytes = static_cast<std::int64_t>(std::min(2.0 * 4.0 * voxels, 1e18));
  // Each CMA-ES sample: its waypoints, the trajectory and its scored poses
  // (a population of 2,000,000 was seen holding 787 MB, about 400 bytes a
  // sample; counted as 1 KB to leave room).
  e.planner_bytes = static_cast<std::int64_t>(config.planner.oaipp.population) * 1024;
  return e;
}

}  // namespace oaipp::server
