#include "server/registry.h"

#include <openssl/rand.h>

#include <algorithm>

#include <atomic>
#include <limits>
#include <thread>

#include "absl/cleanup/cleanup.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/time.h"
#include "api/spec.h"
#include "api/status.h"
#include "core/common/status_macros.h"

namespace oaipp::server {
namespace {}  // namespace

MissionRegistry::MissionRegistry(RegistryLimits limits, MissionStore* store)
    : limits_(limits), caches_(limits.prior_cache), store_(store) {
  if (store_ != nullptr && limits_.snapshot_every > 0) {
    snapshots_.Start([this](const std::string& mission_id) { TakeSnapshot(mission_id); });
  }
}

MissionRegistry::~MissionRegistry() { snapshots_.Stop(); }

absl::StatusOr<std::shared_ptr<Mission>> MissionRegistry::Create(std::string mission_id,
                                                                 MissionConfig config,
                                                                 const std::string& request_id,
                                                                 const std::string& fingerprint,
                                                                 const std::string& tenant) {
  if (!mission_id.empty() && !ValidMissionId(mission_id)) {
    return absl::InvalidArgumentError(
        absl::StrCat("mission_id: must match [a-z0-9-]{1,63}, got ", api::EchoInput(mission_id)));
  }
  const double cells = config.CellCount();
  if (cells > static_cast<double>(limits_.max_cells_per_mission)) {
    return absl::ResourceExhaustedError(absl::StrFormat(
        "spec.field: %.0f cells exceed this server's limit of %d per mission; use a coarser "
        "resolution_m or a smaller field",
        cells, limits_.max_cells_per_mission));
  }
  // The spec as stored names the map it got, so that every server that
  // reads the mission back holds the same map.
  config.map_backend = config.ResolveMapBackend(limits_.max_dense_cells);
  if (config.map_backend == api::MapBackend::kDense &&
      cells > static_cast<double>(limits_.max_dense_cells)) {
    return absl::ResourceExhaustedError(absl::StrFormat(
        "spec.field.map_backend: a dense map of %.0f cells (its covariance would take %.0f MB) "
        "exceeds this server's limit of %d; ask for MAP_BACKEND_SPARSE or leave it unspecified",
        cells, 8.0 * cells * cells / 1e6, limits_.max_dense_cells));
  }
  OAIPP_ASSIGN_OR_RETURN(const std::int64_t estimate, AdmitMemory(config));
  // request_ids, like mission ids, are the tenant's own.
  const std::string request_key = request_id.empty() ? "" : MissionKey(tenant, request_id);
  const auto reused = [&](absl::string_view created_id) {
    return absl::InvalidArgumentError(absl::StrCat(
        "request_id: ", api::EchoInput(request_id), " was first used to create mission '",
        PublicId(created_id), "' with a different request; a new mission needs a new request_id"));
  };
  // With a shared store, the first attempt of a retried create may have
  // reached another server: the store knows what the request_id created.
  if (limits_.shared_store && !request_key.empty()) {
    std::string created_id;
    std::string created_print;
    {
      absl::MutexLock lock(&mu_);
      if (const auto* created = created_by_request_.Find(request_key)) {
        std::tie(created_id, created_print) = *created;
      }
    }
    if (created_id.empty()) {
      absl::StatusOr<StoredMission> found = store_->CreatedBy(request_key);
      if (found.ok()) {
        created_id = found->id;
        created_print = found->fingerprint;
      } else if (found.status().code() != absl::StatusCode::kNotFound) {
        return found.status();
      }
    }
    if (!created_id.empty()) {
      if (!fingerprint.empty() && !created_print.empty() && fingerprint != created_print) {
        return reused(created_id);
      }
      absl::StatusOr<std::shared_ptr<Mission>> held =
          Hold(created_id, Find(created_id), MissionName(created_id));
      if (held.status().code() == absl::StatusCode::kNotFound) {
        return absl::FailedPreconditionError(
            absl::StrCat("request_id: ", api::EchoInput(request_id), " created mission '",
                         PublicId(created_id), "', which is gone"));
      }
      return held;
    }
  }
  std::string key;
  {
    absl::MutexLock lock(&mu_);
    if (const auto* created = created_by_request_.Find(request_key)) {
      const auto& [created_id, created_print] = *created;
      if (!fingerprint.empty() && !created_print.empty() && fingerprint != created_print) {
        return reused(created_id);
      }
      auto m = missions_.find(created_id);
      if (m != missions_.end() && m->second != nullptr) return m->second;
      return absl::FailedPreconditionError(absl::StrCat("request_id: ", api::EchoInput(request_id),
                                                        " created mission '", PublicId(created_id),
                                                        "', which is gone or still being built"));
    }
    if (mission_id.empty()) {
      // With a store the number comes from it, so ids never repeat across
      // restarts (a retry of an old request cannot land in a new mission).
      do {
        std::int64_t number = next_id_++;
        if (store_ != nullptr) {
          OAIPP_ASSIGN_OR_RETURN(number, store_->NextMissionNumber());
        }
        mission_id = absl::StrFormat("m-%06d", number);
      } while (missions_.contains(MissionKey(tenant, mission_id)));
    }
    key = MissionKey(tenant, mission_id);
    if (missions_.contains(key)) {
      return absl::AlreadyExistsError(
          absl::StrCat("mission_id: '", mission_id, "' already exists"));
    }
    if (static_cast<int>(missions_.size()) >= limits_.max_missions) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "this server holds its limit of ", limits_.max_missions, " missions; delete one first"));
    }
    if (limits_.max_missions_per_tenant > 0) {
      int own = 0;
      for (const auto& [k, m] : missions_) own += TenantOfKey(k) == tenant ? 1 : 0;
      if (own >= limits_.max_missions_per_tenant) {
        return absl::ResourceExhaustedError(
            absl::StrCat("your quota is ", limits_.max_missions_per_tenant,
                         " missions and you hold them all; delete one first"));
      }
    }
    if (limits_.max_memory_bytes > 0 && ReservedBytes() + estimate > limits_.max_memory_bytes) {
      return absl::ResourceExhaustedError(absl::StrFormat(
          "spec: this server's missions already need about %.0f MB of its %.0f MB; this one "
          "would need %.0f MB more; delete a mission or use a coarser spec",
          ReservedBytes() / 1e6, limits_.max_memory_bytes / 1e6, estimate / 1e6));
    }
    missions_[key] = nullptr;  // reserve the id while the map is built
    building_bytes_[key] = estimate;
    TrimStandbys();
  }
  // Whatever happens while the mission is built (an error, or an exception
  // such as running out of memory), a reservation that did not become a
  // mission is released, so the id and the slot are free again.
  auto release = absl::MakeCleanup([&] {
    absl::MutexLock lock(&mu_);
    if (auto it = missions_.find(key); it != missions_.end() && it->second == nullptr) {
      missions_.erase(it);
    }
    building_bytes_.erase(key);
  });
  // The effective spec, written with every default filled in (only when
  // there is a store to write it to).
  const std::string spec =
      store_ != nullptr ? api::ConfigToMissionSpec(config).SerializeAsString() : std::string();
  ApplyServerSettings(config);
  absl::StatusOr<std::shared_ptr<Mission>> mission =
      Mission::Create(key, std::move(config), caches_.view());
  if (mission.ok()) {
    (*mission)->set_memory_budget(estimate, LogLimit(estimate));
    WatchForSnapshots(**mission);
  }
  if (mission.ok() && store_ != nullptr) {
    const absl::Status stored = store_->CreateMission(
        {.id = key,
         .spec = spec,
         .request_id = request_key,
         .fingerprint = fingerprint,
         .create_time_unix_us = absl::ToUnixMicros((*mission)->Snapshot().create_time)});
    if (!stored.ok()) mission = stored;
  }
  if (!mission.ok()) return mission.status();
  if (limits_.shared_store) KeepLease(**mission);  // this server's from the start
  absl::MutexLock lock(&mu_);
  std::move(release).Cancel();
  building_bytes_.erase(key);
  Register(key, *mission);
  if (!request_key.empty()) {
    created_by_request_.Remember(request_key, {key, fingerprint});
  }
  return mission;
}

void MissionRegistry::ApplyServerSettings(MissionConfig& config) const {
  config.planner.common.information.single_precision = limits_.single_precision_objective;
  config.planner.common.information.dense_backend = limits_.dense_backend;
}

void MissionRegistry::Register(const std::string& key, std::shared_ptr<Mission> mission) {
  missions_[key] = std::move(mission);
  if (!number_of_.contains(key)) {
    number_of_[key] = next_number_;
    order_[next_number_++] = key;
  }
  TrimStandbys();  // a mission taken over may need what a standby holds
}

std::shared_ptr<Mission> MissionRegistry::Find(const std::string& key) const {
  absl::MutexLock lock(&mu_);
  auto it = missions_.find(key);
  return it == missions_.end() ? nullptr : it->second;
}

absl::StatusOr<std::int64_t> MissionRegistry::AdmitMemory(const MissionConfig& config) const {
  const MemoryEstimate e = EstimateMissionBytes(config);
  if (limits_.max_mission_memory_bytes > 0 && e.total() > limits_.max_mission_memory_bytes) {
    return absl::ResourceExhaustedError(absl::StrFormat(
        "spec: the mission would need about %.0f MB (map %.0f, ESDF %.0f, planner %.0f); this "
        "server allows %.0f MB per mission; use a coarser resolution_m or voxel_size_m, a lower "
        "max_altitude_m or a smaller population",
        e.total() / 1e6, e.map_bytes / 1e6, e.esdf_bytes / 1e6, e.planner_bytes / 1e6,
        limits_.max_mission_memory_bytes / 1e6));
  }
  return e.total();
}

std::int64_t MissionRegistry::LogLimit(std::int64_t estimate) const {
  if (limits_.max_mission_memory_bytes <= 0) return std::numeric_limits<std::int64_t>::max();
  return std::max<std::int64_t>(0, limits_.max_mission_memory_bytes - estimate);
}

std::int64_t MissionRegistry::ReservedBytes() const {
  std::int64_t total = 0;
  for (const auto& [key, mission] : missions_) {
    if (mission != nullptr) {
      total += mission->memory_estimate() + mission->LogBytes();
    }
  }
  for (const auto& [key, bytes] : building_bytes_) total += bytes;
  return total;
}

absl::StatusOr<int> MissionRegistry::Recover() {
  // Servers sharing a store take missions over one by one, as calls come.
  if (store_ == nullptr || limits_.shared_store) return 0;
  OAIPP_ASSIGN_OR_RETURN(std::vector<StoredMission> stored, store_->LoadAll());
  // Missions are rebuilt beside each other (each replays only its own
  // tail); they are registered in creation order.
  std::vector<absl::StatusOr<std::shared_ptr<Mission>>> rebuilt(stored.size(),
                                                                absl::UnknownError("not rebuilt"));
  std::atomic<std::size_t> next{0};
  const auto work = [&] {
    for (std::size_t i = next++; i < stored.size(); i = next++) rebuilt[i] = Rebuild(stored[i]);
  };
  std::vector<std::thread> threads;
  for (int t = 1; t < limits_.recovery_threads; ++t) threads.emplace_back(work);
  work();
  for (std::thread& t : threads) t.join();
  int recovered = 0;
  for (std::size_t i = 0; i < stored.size(); ++i) {
    if (!rebuilt[i].ok()) {
      return absl::Status(
          rebuilt[i].status().code(),
          absl::StrCat("recovering mission '", stored[i].id, "': ", rebuilt[i].status().message()));
    }
    absl::MutexLock lock(&mu_);
    missions_[stored[i].id] = *std::move(rebuilt[i]);
    number_of_[stored[i].id] = next_number_;
    order_[next_number_++] = stored[i].id;
    created_by_request_.Remember(stored[i].request_id, {stored[i].id, stored[i].fingerprint});
    ++recovered;
  }
  // A mission read back with a long tail (its last snapshot was not written
  // before the stop) is snapshotted now, so the next start is quick.
  for (const std::shared_ptr<Mission>& m : List(0, static_cast<std::size_t>(-1))) {
    m->MaybeWantSnapshot();
  }
  return recovered;
}

absl::Status MissionRegistry::Reload(const std::string& mission_id) {
  if (store_ == nullptr) return absl::OkStatus();
  OAIPP_ASSIGN_OR_RETURN(StoredMission stored, store_->Load(mission_id));
  absl::StatusOr<std::shared_ptr<Mission>> mission = Rebuild(stored);
  if (!mission.ok()) {
    return absl::Status(mission.status().code(), absl::StrCat("reloading mission '", mission_id,
                                                              "': ", mission.status().message()));
  }
  std::shared_ptr<Mission> old;
  {
    absl::MutexLock lock(&mu_);
    auto it = missions_.find(mission_id);
    if (it == missions_.end() || it->second == nullptr) return absl::OkStatus();  // deleted since
    if (it->second->lease().epoch() == stored.epoch) old = std::exchange(it->second, *mission);
  }
  if (old == nullptr) {
    // Another server claimed it: what it wrote is no longer this server's.
    Drop(mission_id, Find(mission_id),
         absl::UnavailableError(absl::StrCat("name: mission 'missions/", PublicId(mission_id),
                                             "' moved to another server; watch it again")));
    return absl::OkStatus();
  }
  old->events().HandTo((*mission)->events());
  return absl::OkStatus();
}

absl::StatusOr<std::shared_ptr<Mission>> MissionRegistry::Get(absl::string_view name,
                                                              const std::string& tenant) const {
  OAIPP_ASSIGN_OR_RETURN(std::string id, ParseMissionName(name));
  // Another tenant's mission is not found, in the same words as a missing
  // one: whether it exists is not the caller's to know (keys carry the
  // tenant, in memory and in the store).
  const std::string key = MissionKey(tenant, id);
  std::shared_ptr<Mission> held = Find(key);
  if (limits_.shared_store) {
    return const_cast<MissionRegistry*>(this)->Hold(key, std::move(held), name);
  }
  if (held == nullptr) return absl::NotFoundError(absl::StrCat("name: no mission '", name, "'"));
  return held;
}

absl::StatusOr<std::shared_ptr<Mission>> MissionRegistry::GetHeld(absl::string_view name,
                                                                  const std::string& tenant) const {
  OAIPP_ASSIGN_OR_RETURN(std::string id, ParseMissionName(name));
  std::shared_ptr<Mission> held = Find(MissionKey(tenant, id));
  if (held == nullptr) return absl::NotFoundError(absl::StrCat("name: no mission '", name, "'"));
  return held;
}

std::vector<std::shared_ptr<Mission>> MissionRegistry::List(std::size_t offset,
                                                            std::size_t limit) const {
  absl::MutexLock lock(&mu_);
  std::vector<std::shared_ptr<Mission>> out;
  auto it = order_.begin();
  for (std::size_t i = 0; i < offset && it != order_.end(); ++i) ++it;
  for (; it != order_.end() && out.size() < limit; ++it) out.push_back(missions_.at(it->second));
  return out;
}

std::vector<std::pair<std::int64_t, std::shared_ptr<Mission>>> MissionRegistry::ListAfter(
    std::int64_t after, std::size_t limit, const std::string& tenant) const {
  absl::MutexLock lock(&mu_);
  std::vector<std::pair<std::int64_t, std::shared_ptr<Mission>>> out;
  for (auto it = order_.upper_bound(after); it != order_.end() && out.size() < limit; ++it) {
    if (TenantOfKey(it->second) != tenant) continue;
    out.emplace_back(it->first, missions_.at(it->second));
  }
  return out;
}

absl::StatusOr<std::vector<MissionRegistry::Listed>> MissionRegistry::ListStored(
    const std::string& tenant, std::int64_t after_time_us, const std::string& after_key,
    int limit) const {
  if (store_ == nullptr) return absl::FailedPreconditionError("no store to list");
  OAIPP_ASSIGN_OR_RETURN(std::vector<MissionListing> stored,
                         store_->List(tenant.empty() ? std::string() : MissionKey(tenant, ""),
                                      after_time_us, after_key, limit));
  std::vector<Listed> out;
  out.reserve(stored.size());
  absl::MutexLock lock(&mu_);
  for (MissionListing& m : stored) {
    const auto it = missions_.find(m.id);
    std::shared_ptr<Mission> held = it != missions_.end() ? it->second : nullptr;
    out.push_back({.stored = std::move(m), .held = std::move(held)});
  }
  return out;
}

absl::StatusOr<std::string> MissionRegistry::PageTokenKey() const {
  absl::MutexLock lock(&key_mu_);
  if (!page_token_key_.empty()) return page_token_key_;
  if (store_ != nullptr) {
    OAIPP_ASSIGN_OR_RETURN(page_token_key_, store_->SigningKey());
  } else {
    page_token_key_.assign(32, '\0');
    if (RAND_bytes(reinterpret_cast<unsigned char*>(page_token_key_.data()), 32) != 1) {
      page_token_key_.clear();
      return absl::InternalError("page tokens: no random bytes for their key");
    }
  }
  return page_token_key_;
}

absl::Status MissionRegistry::Delete(absl::string_view name, const std::string& request_id,
                                     const std::string& tenant) {
  OAIPP_ASSIGN_OR_RETURN(std::string id, ParseMissionName(name));
  const std::string key = MissionKey(tenant, id);
  if (limits_.shared_store) {
    // Deleted where it is held; a mission already gone is left to
    // DeleteKey, which tells a retry from a miss.
    absl::StatusOr<std::shared_ptr<Mission>> held = Hold(key, Find(key), name);
    if (!held.ok() && held.status().code() != absl::StatusCode::kNotFound) return held.status();
  }
  return DeleteKey(key, request_id.empty() ? "" : MissionKey(tenant, request_id), request_id);
}

absl::Status MissionRegistry::DeleteKey(const std::string& id, const std::string& request_key,
                                        const std::string& request_id) {
  const std::string name = MissionName(id);
  std::shared_ptr<Mission> mission;
  absl::Status fenced;
  absl::MutexLock write_lock(&snapshot_write_mu_);
  {
    absl::MutexLock lock(&mu_);
    // A retry of a delete is answered OK; the same request_id used to
    // delete another mission is refused.
    const auto same_delete = [&](const std::string& deleted) -> absl::Status {
      if (deleted == id) return absl::OkStatus();
      return absl::InvalidArgumentError(absl::StrCat(
          "request_id: ", api::EchoInput(request_id), " deleted mission '", PublicId(deleted),
          "', not '", PublicId(id), "'; a new request needs a new id"));
    };
    if (!request_key.empty()) {
      if (const std::string* deleted = deleted_by_request_.Find(request_key)) {
        return same_delete(*deleted);
      }
      // Used by a delete before a restart?
      if (store_ != nullptr) {
        if (absl::StatusOr<std::string> deleted = store_->DeletedBy(request_key); deleted.ok()) {
          return same_delete(*deleted);
        }
      }
    }
    auto it = missions_.find(id);
    if (it == missions_.end() || it->second == nullptr) {
      return absl::NotFoundError(absl::StrCat("name: no mission '", name, "'"));
    }
    mission = it->second;
    // Durable first: a failed delete leaves the mission in place.
    if (store_ != nullptr) {
      const absl::Status deleted = store_->DeleteMission(id, request_key, mission->lease().epoch());
      if (deleted.GetPayload(kFenced).has_value()) {
        fenced = deleted;
      } else if (!deleted.ok()) {
        return deleted;
      }
    }
    if (fenced.ok()) {
      missions_.erase(it);
      order_.erase(number_of_[id]);
      number_of_.erase(id);
      if (!request_key.empty()) deleted_by_request_.Remember(request_key, id);
    }
  }
  // Another server holds the mission now: this copy goes, and the retry
  // deletes it there.
  if (!fenced.ok()) return AfterFailedWrite(mission, fenced);
  mission->events().MarkDeleted();
  return absl::OkStatus();
}

std::size_t MissionRegistry::size() const {
  absl::MutexLock lock(&mu_);
  return order_.size();
}

std::int64_t MissionRegistry::MemoryBytes() const {
  std::vector<std::shared_ptr<Mission>> all = List(0, static_cast<std::size_t>(-1));
  std::int64_t total = 0;
  for (const auto& m : all) total += m->MemoryBytes();
  return total;
}

}  // namespace oaipp::server
