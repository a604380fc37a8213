// Worlds already built, by what they were built from: a fleet of missions
// over one site builds its ESDF once and clones it (the clones share the
// grid, copy on write) instead of each building the same grid again.
//
// Thread-safe. Holds at most `capacity` worlds (the least recently used is
// dropped beyond that); while missions hold clones, a held world costs only
// its obstacle list (the grid is shared). Concurrent first requests for one
// key build it once; the others wait for it. A failed build is not
// remembered.
//
//   WorldCache worlds(/*capacity=*/4);
//   OAIPP_ASSIGN_OR_RETURN(Environment env,
//                          worlds.Get(key, [&] { return config.MakeEnvironment(); }));
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "absl/status/statusor.h"
#include "core/common/single_flight_cache.h"
#include "core/environment/environment.h"

namespace oaipp {

class WorldCache {
 public:
  explicit WorldCache(int capacity = 4);

  // A clone of the world built for `key` (by `build`, on the first request:
  // the key must say everything the build depends on). Errors are build's.
  [[nodiscard]] absl::StatusOr<Environment> Get(
      const std::string& key, const std::function<absl::StatusOr<Environment>()>& build);

  // Worlds built (cache misses).
  [[nodiscard]] std::int64_t builds() const;
  // True when a world held here uses the ESDF values at `values` (so that
  // memory accounting does not count the cache as one more user).
  [[nodiscard]] bool HoldsGrid(const void* grid_id) const;

 private:
  SingleFlightCache<std::string, Environment> worlds_;
};

}  // namespace oaipp
