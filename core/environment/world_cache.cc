#include "core/environment/world_cache.h"

#include <algorithm>
#include <chrono>
#include <utility>

namespace oaipp {

WorldCache::WorldCache(int capacity) : capacity_(std::max(capacity, 1)) {}

absl::StatusOr<Environment> WorldCache::Get(
    const std::string& key, const std::function<absl::StatusOr<Environment>()>& build) {
  std::shared_future<Result> world;
  std::promise<Result> promise;
  bool building = false;
  std::uint64_t inserted = 0;
  {
    absl::MutexLock lock(&mu_);
    auto it = std::find_if(entries_.begin(), entries_.end(),
                           [&](const Entry& e) { return e.key == key; });
    if (it != entries_.end()) {
      it->last_used = ++clock_;
      world = it->world;
    } else {
      if (static_cast<int>(entries_.size()) >= capacity_) {
        // Waiters on a dropped world hold their own copy of its future.
        entries_.erase(std::min_element(
            entries_.begin(), entries_.end(),
            [](const Entry& a, const Entry& b) { return a.last_used < b.last_used; }));
      }
      world = promise.get_future().share();
      inserted = ++clock_;
      entries_.push_back({key, world, inserted, inserted});
      ++builds_;
      building = true;
    }
  }
  if (building) {
    absl::StatusOr<Environment> built = build();
    if (built.ok()) {
      promise.set_value(std::make_shared<const Environment>(*std::move(built)));
    } else {
      promise.set_value(built.status());
      absl::MutexLock lock(&mu_);
      std::erase_if(entries_, [&](const Entry& e) { return e.inserted == inserted; });
    }
  }
  const Result& result = world.get();
  if (!result.ok()) return result.status();
  return (*result)->Clone();
}

bool WorldCache::HoldsGrid(const float* values) const {
  absl::MutexLock lock(&mu_);
  for (const Entry& e : entries_) {
    if (e.world.wait_for(std::chrono::seconds(0)) != std::future_status::ready) continue;
    const Result& world = e.world.get();
    if (world.ok() && (*world)->esdf().values().data() == values) return true;
  }
  return false;
}

std::int64_t WorldCache::builds() const {
  absl::MutexLock lock(&mu_);
  return builds_;
}

}  // namespace oaipp
