// The server's missions by id, with the limits that protect the machine.
//
//   MissionRegistry registry({.max_missions = 64});
//   OAIPP_ASSIGN_OR_RETURN(auto mission, registry.Create("", config, request_id));
//   OAIPP_ASSIGN_OR_RETURN(auto same, registry.Get("missions/" + mission->id()));
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "core/mapping/prior_cache.h"
#include "server/mission.h"
#include "server/request_memo.h"
#include "server/store/mission_store.h"

namespace oaipp::server {

struct RegistryLimits {
  // Missions held at once. Valid: >= 1.
  int max_missions = 64;
  // Cells of one mission's map: its covariance costs 8 n^2 bytes (1600 cells:
  // 20 MB; 4096 cells: 134 MB). Valid: >= 1.
  std::int64_t max_cells_per_mission = 4096;
  // Prior covariances kept for missions over the same kind of field (8 n^2
  // bytes each); 0: every mission computes its own. Valid: >= 0.
  int prior_cache = 4;
};

class MissionRegistry {
 public:
  // store: where missions are kept durably (must outlive the registry);
  // nullptr keeps them in memory only.
  explicit MissionRegistry(RegistryLimits limits, MissionStore* store = nullptr)
      : limits_(limits),
        priors_(limits.prior_cache > 0 ? std::make_unique<PriorCache>(limits.prior_cache)
                                       : nullptr),
        store_(store) {}

  // Loads every mission of the store and replays its log: the same
  // obstacles, map, counters, planner state and request_id records as
  // before the restart. Call once, before serving. Returns how many missions
  // came back; an error names the mission and record that could not be
  // read (the registry then holds the missions before it).
  [[nodiscard]] absl::StatusOr<int> Recover();

  // Creates a mission. mission_id: [a-z0-9-]{1,63}, or empty for a new one.
  // InvalidArgument for a bad id, AlreadyExists for a taken one,
  // ResourceExhausted past max_missions or max_cells_per_mission. A retry
  // with the same non-empty request_id returns the mission first created.
  // With a store, the mission's spec is written durably before it is
  // answered (Unavailable, or ResourceExhausted for a full disk, when that
  // fails; the id is then free again); fingerprint identifies the request
  // behind request_id.
  [[nodiscard]] absl::StatusOr<std::shared_ptr<Mission>> Create(
      std::string mission_id, MissionConfig config, const std::string& request_id,
      const std::string& fingerprint = "");
  // name: "missions/{mission_id}". InvalidArgument if malformed, NotFound.
  [[nodiscard]] absl::StatusOr<std::shared_ptr<Mission>> Get(absl::string_view name) const;
  // Missions in creation order from `offset`, at most `limit`.
  [[nodiscard]] std::vector<std::shared_ptr<Mission>> List(std::size_t offset,
                                                           std::size_t limit) const;
  // Removes a mission (watchers are told), from the store first when there
  // is one. NotFound unless it exists or the same request_id deleted it
  // before (also before a restart).
  [[nodiscard]] absl::Status Delete(absl::string_view name, const std::string& request_id);
  [[nodiscard]] std::size_t size() const;
  // The durable store, or nullptr.
  [[nodiscard]] MissionStore* store() const { return store_; }
  [[nodiscard]] std::int64_t MemoryBytes() const;
  // Prior covariances computed so far (missions of one grid shape and GP
  // parameters share one).
  // (0 without a cache).
  [[nodiscard]] std::int64_t PriorComputations() const {
    return priors_ != nullptr ? priors_->computations() : 0;
  }

  // "missions/{id}" -> id, or InvalidArgument naming `field`.
  [[nodiscard]] static absl::StatusOr<std::string> ParseName(absl::string_view name,
                                                             absl::string_view field = "name");

 private:
  const RegistryLimits limits_;
  // Prior covariances shared by missions over the same kind of field: a
  // fleet computes each once (0.3 s for 1600 cells) and copies it.
  const std::unique_ptr<PriorCache> priors_;
  MissionStore* const store_;
  mutable absl::Mutex mu_;
  // nullptr while a mission is being built (its id is reserved).
  std::map<std::string, std::shared_ptr<Mission>> missions_ ABSL_GUARDED_BY(mu_);
  std::vector<std::string> order_ ABSL_GUARDED_BY(mu_);
  std::int64_t next_id_ ABSL_GUARDED_BY(mu_) = 1;
  // request_id -> the mission it created / deleted.
  RequestMemo<std::string> created_by_request_ ABSL_GUARDED_BY(mu_);
  RequestMemo<std::string> deleted_by_request_ ABSL_GUARDED_BY(mu_);
};

}  // namespace oaipp::server
