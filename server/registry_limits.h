// The limits that protect the machine from the missions a server holds
// (RegistryLimits), and what one mission may need at its peak
// (EstimateMissionBytes, for memory admission).
//
//   const RegistryLimits limits{.max_missions = 64, .max_memory_bytes = 8LL << 30};
//   std::int64_t need = EstimateMissionBytes(config).total();
#pragma once

#include <cstdint>
#include <string>

#include "absl/time/time.h"
#include "api/mission_config.h"
#include "core/mapping/dense_backend.h"

namespace oaipp::server {

struct RegistryLimits {
  // Missions held at once. Valid: >= 1.
  int max_missions = 64;
  // Cells of one mission's map. Valid: >= 1.
  std::int64_t max_cells_per_mission = 250'000;
  // Cells of the largest dense map (its covariance costs 8 n^2 bytes: 1600
  // cells, 20 MB; 4096 cells, 134 MB), and the field size above which a
  // spec that names no map_backend gets the sparse map. Valid: >= 1.
  std::int64_t max_dense_cells = 4096;
  // Prior covariances kept for missions over the same kind of field, and
  // starting maps (the prior with the ground under a site's obstacles
  // fused) for missions over the same site, each as many (8 n^2 bytes
  // each), and up to two sparse priors of large fields; 0: every mission
  // computes its own. Valid: >= 0.
  int prior_cache = 4;
  // With a store: a snapshot of a mission after this many measurements (or
  // 4 x as many records of any kind) since its last one, so that recovery
  // replays at most that many; 0: never. Valid: >= 0.
  int snapshot_every = 16;
  // Threads that rebuild missions at recovery. Valid: >= 1.
  int recovery_threads = 2;
  // Missions one tenant may hold; 0: only max_missions applies.
  int max_missions_per_tenant = 0;
  // Memory admission (EstimateMissionBytes): what one mission and all of
  // them together may need, checked before anything is allocated; 0: no
  // limit.
  std::int64_t max_mission_memory_bytes = 0;
  std::int64_t max_memory_bytes = 0;
  // Several servers share the store (a cluster on PostgreSQL,
  // docs/cluster.md). Recover then loads nothing: a mission is taken over
  // (MissionStore::Claim, then rebuilt from its snapshot and log tail) by
  // the first call for it that reaches this server, every call checks that
  // this server still holds the mission it names, and a copy another server
  // took over is dropped.
  bool shared_store = false;
  // Shared store: who this server is in the store's leases (its replica
  // id, or a name made at start; Server says it is alive, MissionStore::
  // Heartbeat). A mission stays this server's for `mission_lease` after the
  // last call it served here: while it is alive, a call for it that reaches
  // another server (a forged or stale routing header) is answered
  // UNAVAILABLE there, after waiting up to `silent_after` for the holder to
  // be found silent, and nothing is rebuilt. When the holder falls silent
  // (no heartbeat for `silent_after`) or retires, its missions are free at
  // once; a mission whose calls go elsewhere is free `mission_lease` after
  // its last call here. The lease must outlast the wait: renewed every
  // quarter of it, at least 3/4 of it is left when a call reaches another
  // server, so mission_lease > 4/3 silent_after (the server gives it 4 x
  // silent_after, --silent_after).
  std::string holder = {};
  absl::Duration mission_lease = absl::Seconds(2);
  absl::Duration silent_after = absl::Milliseconds(500);
  // Shared store: this server's id on the proxies' ring (HAProxy's server
  // `id`; HashRing), 0 when the proxies' ring is not known. With it, the
  // server keeps warm standbys (KeepStandbys): up to `max_standbys` of the
  // missions the proxies would send it if their live holder died, read and
  // replayed ahead, so that a takeover reads only what was written since.
  // Valid: >= 0.
  int ring_id = 0;
  int max_standbys = 64;
  // Not limits but server-wide settings every mission gets (they are not
  // part of the spec, so a restored mission takes this server's): the
  // adaptive objective's solves in single precision
  // (InformationParams::single_precision, --objective_precision), and where
  // the map's and the objective's dense products run
  // (InformationParams::dense_backend, --dense_backend).
  bool single_precision_objective = false;
  DenseBackend dense_backend = {};
};

// What a mission of `config` may hold at its peak, in bytes: its map (mean
// and covariance, twice: a plan reads one copy while a measurement writes
// another), its ESDF (twice: an obstacle change builds the next one beside
// the current), and the planner's CMA-ES population. Estimated from the
// config alone, before anything is allocated.
struct MemoryEstimate {
  std::int64_t map_bytes = 0;
  std::int64_t esdf_bytes = 0;
  std::int64_t planner_bytes = 0;
  [[nodiscard]] std::int64_t total() const { return map_bytes + esdf_bytes + planner_bytes; }
};
[[nodiscard]] MemoryEstimate EstimateMissionBytes(const api::MissionConfig& config);

}  // namespace oaipp::server
