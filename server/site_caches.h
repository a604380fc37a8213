// What missions over the same site share instead of computing again (the
// prior covariance, the ESDF, the world, the starting map), and the keys a
// mission's world and starting map are found by in those caches.
//
//   StartMapCache start_maps{/*capacity=*/4};
//   const SiteCaches caches{.esdfs = &esdfs, .worlds = &worlds, .start_maps = &start_maps};
//   OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> m, Mission::Create("m1", config, caches));
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "api/mission_config.h"
#include "core/common/single_flight_cache.h"
#include "core/environment/esdf.h"
#include "core/environment/world_cache.h"
#include "core/mapping/gmrf_prior.h"
#include "core/mapping/gp_map.h"
#include "core/mapping/gp_params.h"
#include "core/mapping/prior_cache.h"
#include "core/planning/information.h"

namespace oaipp::server {

// A map at the prior with the ground under a site's obstacles already fused
// (what Mission::Create starts from), by everything it is computed from: the
// field, the obstacles and the GP parameters. The fusion is a rank-m Kalman
// update over every cell under a building (m in the hundreds for a town),
// so a fleet over one site does it once. The missions hold the map itself
// until their first measurement copies it (copy on write, as a plan holds
// the map it started from), so creating one costs no copy of it either.
struct StartMap {
  std::shared_ptr<GpMap> map;      // never changed while shared
  std::vector<int> covered_cells;  // the cells fused, in the order fused
  // The map conditioned on a first shot, for the first plans of the
  // missions still holding `map` (a fleet starting from one point conditions
  // it on the same shot): two entries of 8 n^2 bytes, kept while the site's
  // cache or such a mission holds this (a plan in progress keeps its own).
  std::shared_ptr<ConditionedCache> conditioned = std::make_shared<ConditionedCache>(2);
};
using StartMapCache = SingleFlightCache<std::string, StartMap>;

// What missions over the same site share instead of computing again; a null
// pointer makes each mission compute its own. Sharing never changes a
// mission's numbers: every cache hands out what the mission would compute.
struct SiteCaches {
  // The prior covariance, per grid shape and GP parameters.
  PriorCache* priors = nullptr;
  // One ESDF for missions over equal worlds (also after obstacle changes
  // that make two worlds equal).
  EsdfPool* esdfs = nullptr;
  // Worlds already built for the same field, flight settings and
  // obstacles, cloned instead of built again.
  WorldCache* worlds = nullptr;
  // Starting maps (StartMap), copied instead of fused again.
  StartMapCache* start_maps = nullptr;
  // The sparse prior of a large field, per grid shape and GP parameters.
  GmrfPriorCache* gmrf_priors = nullptr;
};

// The caches of one server, made and owned together: `capacity` entries
// each of priors and starting maps (8 n^2 bytes each), up to two sparse
// priors of large fields; capacity 0 leaves those three out (every mission
// computes its own). ESDFs and worlds are always shared.
class SiteCacheSet {
 public:
  explicit SiteCacheSet(int capacity);
  SiteCacheSet(const SiteCacheSet&) = delete;
  SiteCacheSet& operator=(const SiteCacheSet&) = delete;
  // What Mission::Create takes.
  [[nodiscard]] const SiteCaches& view() const { return view_; }
  // Priors, dense and sparse, computed rather than found (0 without them).
  [[nodiscard]] std::int64_t PriorComputations() const;
  [[nodiscard]] std::int64_t GmrfPriorComputations() const;

 private:
  const std::unique_ptr<PriorCache> priors_;
  EsdfPool esdfs_;
  WorldCache worlds_;
  const std::unique_ptr<StartMapCache> start_maps_;
  const std::unique_ptr<GmrfPriorCache> gmrf_priors_;
  const SiteCaches view_;
};

// Everything a mission's world is built from (MakeEnvironment): the field,
// the flight settings (altitudes, ESDF voxel and truncation), the ESDF's
// voxel limit and the obstacles, as bytes.
[[nodiscard]] std::string WorldKey(const api::MissionConfig& config);

// The key of a site's StartMap: its world's key, the GP parameters and the
// prior map's values, exactly (hexadecimal floats, the map's bytes).
[[nodiscard]] std::string StartMapKey(const std::string& world_key,
                                      const api::MissionConfig& config);

}  // namespace oaipp::server
