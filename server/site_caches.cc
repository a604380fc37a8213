#include "server/site_caches.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "api/spec.h"

namespace oaipp::server {

SiteCacheSet::SiteCacheSet(int capacity)
    : priors_(capacity > 0 ? std::make_unique<PriorCache>(capacity) : nullptr),
      start_maps_(capacity > 0 ? std::make_unique<StartMapCache>(capacity) : nullptr),
      gmrf_priors_(capacity > 0 ? std::make_unique<GmrfPriorCache>(std::min(capacity, 2))
                                : nullptr),
      view_{.priors = priors_.get(),
            .esdfs = &esdfs_,
            .worlds = &worlds_,
            .start_maps = start_maps_.get(),
            .gmrf_priors = gmrf_priors_.get()} {}

std::int64_t SiteCacheSet::PriorComputations() const {
  return priors_ != nullptr ? priors_->computations() : 0;
}

std::int64_t SiteCacheSet::GmrfPriorComputations() const {
  return gmrf_priors_ != nullptr ? gmrf_priors_->computations() : 0;
}

std::string WorldKey(const api::MissionConfig& config) {
  const v1::MissionSpec spec = api::ConfigToMissionSpec(config);
  v1::MissionSpec world;
  *world.mutable_field() = spec.field();
  *world.mutable_flight() = spec.flight();
  *world.mutable_obstacles() = spec.obstacles();
  *world.mutable_fence() = spec.fence();
  *world.mutable_no_fly_zones() = spec.no_fly_zones();
  return absl::StrCat(world.SerializeAsString(), "|", config.esdf.max_voxels, "|",
                      config.esdf.voxel_size_m, "|", config.esdf.truncation_m);
}

std::string StartMapKey(const std::string& world_key, const api::MissionConfig& config) {
  const GpParams& gp = config.gp;
  std::string key = absl::StrFormat("%s|%a|%a|%a|%a|", world_key, gp.length_scale_m, gp.signal_var,
                                    gp.noise_var, gp.prior_mean);
  if (config.prior_map != nullptr) {
    // Dense maps only (at most --max_dense_cells values): a few tens of KB.
    absl::StrAppend(&key, absl::string_view(reinterpret_cast<const char*>(config.prior_map->data()),
                                            config.prior_map->size() * sizeof(double)));
  }
  return key;
}

}  // namespace oaipp::server
