#include "core/environment/world_cache.h"

namespace oaipp {

WorldCache::WorldCache(int capacity) : worlds_(capacity) {}

absl::StatusOr<Environment> WorldCache::Get(
    const std::string& key, const std::function<absl::StatusOr<Environment>()>& build) {
  const auto world = worlds_.Get(key, build);
  if (!world.ok()) return world.status();
  return (*world)->Clone();
}

bool WorldCache::HoldsGrid(const void* grid_id) const {
  return worlds_.AnyHeld(
      [&](const Environment& world) { return world.esdf().grid_id() == grid_id; });
}

std::int64_t WorldCache::builds() const { return worlds_.computations(); }

}  // namespace oaipp
