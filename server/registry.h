// The server's missions by id, with the limits that protect the machine.
//
// registry.cc holds naming, create and delete, memory admission, listing
// and recovery; registry_ownership.cc what a server of a cluster holds and
// takes over; registry_standby.cc the missions it keeps warm in case their
// holder dies; snapshot_writer.cc the snapshots written in the background;
// retention.cc the deletion of finished and idle missions; registry_limits.h
// its limits and a mission's memory estimate.
//
//   MissionRegistry registry({.max_missions = 64});
//   OAIPP_ASSIGN_OR_RETURN(auto mission, registry.Create("", config, request_id));
//   OAIPP_ASSIGN_OR_RETURN(auto same, registry.Get("missions/" + mission->id()));
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/synchronization/notification.h"
#include "absl/time/time.h"
#include "server/mission.h"
#include "server/mission_names.h"
#include "server/registry_limits.h"
#include "server/request_memo.h"
#include "server/site_caches.h"
#include "server/snapshot_writer.h"
#include "server/store/mission_store.h"

namespace oaipp::server {

class MissionRegistry {
 public:
  // store: where missions are kept durably (must outlive the registry);
  // nullptr keeps them in memory only. With a store and snapshot_every > 0,
  // a thread of the registry writes snapshots in the background.
  explicit MissionRegistry(RegistryLimits limits, MissionStore* store = nullptr);
  // Finishes the snapshot being written; drops those not begun.
  ~MissionRegistry();
  MissionRegistry(const MissionRegistry&) = delete;
  MissionRegistry& operator=(const MissionRegistry&) = delete;

  // Loads every mission of the store and replays its log: the same
  // obstacles, map, counters, planner state and request_id records as
  // before the restart. Call once, before serving. Returns how many missions
  // came back; an error names the mission and record that could not be
  // read (the registry then holds the missions before it).
  [[nodiscard]] absl::StatusOr<int> Recover();

  // Creates a mission. mission_id: [a-z0-9-]{1,63}, or empty for a new one.
  // InvalidArgument for a bad id, AlreadyExists for a taken one,
  // ResourceExhausted past any limit. A retry with the same non-empty
  // request_id (fingerprint: the request behind it) returns the mission
  // first created. With a store, the spec is durable before the answer
  // (Unavailable, or ResourceExhausted for a full disk; the id is free
  // again). tenant: whose mission it is ("" for the anonymous tenant); ids
  // and request_ids are the tenant's own, invisible to other tenants.
  [[nodiscard]] absl::StatusOr<std::shared_ptr<Mission>> Create(std::string mission_id,
                                                                MissionConfig config,
                                                                const std::string& request_id,
                                                                const std::string& fingerprint = "",
                                                                const std::string& tenant = "");
  // name: "missions/{mission_id}". InvalidArgument if malformed, NotFound
  // (also for another tenant's mission, in the same words).
  [[nodiscard]] absl::StatusOr<std::shared_ptr<Mission>> Get(absl::string_view name,
                                                             const std::string& tenant = "") const;
  // As Get, but only a mission this server holds now: never takes one over
  // from a shared store (for read-only views, which must not move missions
  // between the replicas of a cluster).
  [[nodiscard]] absl::StatusOr<std::shared_ptr<Mission>> GetHeld(
      absl::string_view name, const std::string& tenant = "") const;
  // Missions in creation order from `offset`, at most `limit`.
  [[nodiscard]] std::vector<std::shared_ptr<Mission>> List(std::size_t offset,
                                                           std::size_t limit) const;
  // Missions in creation order created after the one numbered `after` (0:
  // from the first), at most `limit`, each with its creation number.
  // Only `tenant`'s missions.
  [[nodiscard]] std::vector<std::pair<std::int64_t, std::shared_ptr<Mission>>> ListAfter(
      std::int64_t after, std::size_t limit, const std::string& tenant = "") const;
  // For servers that share a store: `tenant`'s missions in the store,
  // whoever holds them, in creation order (create time, then key) after the
  // one created at `after_time_us` with key `after_key` ("" and 0: from the
  // first), at most `limit`; each with the mission when this server holds
  // it (nullptr otherwise). Unavailable when the store cannot be read.
  struct Listed {
    MissionListing stored;
    std::shared_ptr<Mission> held;
  };
  [[nodiscard]] absl::StatusOr<std::vector<Listed>> ListStored(const std::string& tenant,
                                                               std::int64_t after_time_us,
                                                               const std::string& after_key,
                                                               int limit) const;
  [[nodiscard]] bool shares_store() const { return limits_.shared_store && store_ != nullptr; }
  // The key page tokens are signed with: the store's (the same for every
  // server sharing it, and across restarts), or without a store one drawn
  // for this process. Unavailable when the store cannot be read.
  [[nodiscard]] absl::StatusOr<std::string> PageTokenKey() const;
  // Removes a mission (watchers are told), from the store first when there
  // is one. NotFound unless it exists or the same request_id deleted it
  // before (also before a restart).
  [[nodiscard]] absl::Status Delete(absl::string_view name, const std::string& request_id,
                                    const std::string& tenant = "");
  [[nodiscard]] std::size_t size() const;

  // Reads a mission back from the store and puts it in place of the one in
  // memory: after a write whose outcome was in doubt (the store may hold a
  // record the mission never applied). Watchers keep watching. With a
  // shared store, a mission another server has taken over meanwhile is
  // dropped instead.
  [[nodiscard]] absl::Status Reload(const std::string& mission_id);

  // After a mutation of `mission` failed: a write refused because another
  // server took the mission over (kFenced) drops this copy; a write in
  // doubt (kInDoubt) reads the mission back. Returns the status the caller
  // should see (Unavailable for the first: retry, the proxy routes the call
  // to the mission's server).
  [[nodiscard]] absl::Status AfterFailedWrite(const std::shared_ptr<Mission>& mission,
                                              absl::Status status);

  // Shared store: drops the copies of missions that another server has
  // taken over (or deleted) since this one read them, so that memory is not
  // held by missions this server no longer serves. Returns their ids.
  std::vector<std::string> DropMoved();

  // Missions taken over from another server (shared store) since start.
  [[nodiscard]] std::int64_t takeovers() const;

  // Shared store with a ring_id: brings the warm standbys up to date: the
  // missions another live server holds that the proxies' ring without it
  // sends here (at most max_standbys, within max_memory_bytes), read once,
  // then followed record by record (MissionStore::LoadAfter). Called often
  // by the server; a takeover from a standby claims only the newer records.
  void KeepStandbys();
  // Missions on standby now, and takeovers that started from one.
  [[nodiscard]] int standbys() const;
  [[nodiscard]] std::int64_t takeovers_from_standby() const;

  // Retention: deletes (with their records) missions finished and unchanged
  // for `keep_finished`, and any unchanged for `keep_idle` (infinite: kept);
  // forgets older deletions' request_ids. Returns the ids deleted.
  std::vector<std::string> Sweep(absl::Time now, absl::Duration keep_finished,
                                 absl::Duration keep_idle);
  // Retention of a shared store, by the server (`holder`) holding its
  // retention lease (for `lease`): deletes up to 100 missions a call that
  // nothing was written to for `keep_idle`, whoever holds them (they answer
  // NOT_FOUND from then on). Returns the ids deleted.
  std::vector<std::string> SweepStore(absl::Time now, absl::Duration keep_idle,
                                      const std::string& holder, absl::Duration lease);

  // Waits until every snapshot asked for so far is written or has failed.
  void FlushSnapshots();
  // Snapshots written since start (for tests and metrics).
  [[nodiscard]] std::int64_t snapshots_written() const;
  // The durable store, or nullptr.
  [[nodiscard]] MissionStore* store() const { return store_; }
  [[nodiscard]] std::int64_t MemoryBytes() const;
  // What missions over one site share, and how often each was computed.
  [[nodiscard]] const SiteCacheSet& site_caches() const { return caches_; }

 private:
  // A mission rebuilt from what the store holds: its snapshot (if any),
  // then the records after it replayed; it writes at stored.epoch.
  // = ReadBackBase, ReplayRecords, Finish (registry_rebuild.cc).
  absl::StatusOr<std::shared_ptr<Mission>> Rebuild(const StoredMission& stored);
  // A mission on its way back from the store, not yet held by anyone.
  struct ReadBack {
    std::shared_ptr<Mission> mission = nullptr;
    std::int64_t last_write_us = 0;  // the latest write time of what it was read from
  };
  // The stored snapshot restored, or without one a new mission from the spec.
  absl::StatusOr<ReadBack> ReadBackBase(const StoredMission& stored);
  // `log` replayed onto it in order (it must go on from its next sequence).
  absl::Status ReplayRecords(ReadBack& read, const std::vector<LogRecord>& log);
  // Ready to serve: the epoch, creation time and log limit of `stored`.
  std::shared_ptr<Mission> Finish(ReadBack read, const StoredMission& stored);
  // Takeover: the mission as the store holds it now, read and rebuilt
  // while the lease is still its silent holder's (TakeOver).
  absl::StatusOr<ReadBack> Prefetch(const std::string& key);
  // A warm standby (KeepStandbys): the mission as read so far, or nothing
  // before its first read or after a failed one.
  struct Standby {
    absl::Mutex mu;
    std::optional<ReadBack> read ABSL_GUARDED_BY(mu);
    // A takeover has it: KeepStandbys must not read the mission again.
    bool taken ABSL_GUARDED_BY(mu) = false;
    std::int64_t bytes = 0;  // its memory estimate, once read (under the registry's mu_)
  };
  // Brings `standby` of `key` up to `last_sequence`: the whole mission the
  // first time (or when a snapshot later than what it has was stored),
  // else the records after what it has.
  absl::Status Follow(const std::string& key, Standby& standby, std::int64_t last_sequence)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(standby.mu);
  // The standby of `key`, taken out of the map (nullptr without one).
  std::shared_ptr<Standby> TakeStandby(const std::string& key);
  // Standbys give way to missions: drops them (the last keys first) until
  // what the missions held and being built need and what the standbys hold
  // fit max_memory_bytes again.
  void TrimStandbys() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // What the standbys hold, by their estimates.
  std::int64_t StandbyBytes() const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Gives a mission's config this server's settings (RegistryLimits).
  void ApplyServerSettings(MissionConfig& config) const;
  // The mission held under `key`, or nullptr.
  std::shared_ptr<Mission> Find(const std::string& key) const;
  // Shared store: `held` (or nullptr) if this server still holds the
  // mission, else the mission taken over from the store; NotFound (naming
  // `name`) when the store has no such mission.
  absl::StatusOr<std::shared_ptr<Mission>> Hold(const std::string& key,
                                                std::shared_ptr<Mission> held,
                                                absl::string_view name);
  // Claims the mission, rebuilds it and holds it, once its lease is this
  // server's (AcquireLease). Concurrent calls for one key share one
  // takeover.
  absl::StatusOr<std::shared_ptr<Mission>> TakeOver(const std::string& key, absl::string_view name);
  // Shared store: the store's lease on serving `key` ("mission/" and the
  // key in hex).
  static std::string LeaseName(const std::string& key);
  // Takes the mission's lease for this server, waiting up to
  // limits_.silent_after for a live holder to fall silent; UNAVAILABLE
  // (naming `name`) while another live server holds it. Calls
  // `holder_failing` once when the holder has missed heartbeats (its alive
  // time runs out within 3/5 of silent_after: two heartbeats missed), so
  // that the wait can be put to use.
  absl::Status AcquireLease(const std::string& key, absl::string_view name,
                            const std::function<void()>& holder_failing);
  // Renews the lease of a mission this server serves when a quarter of it
  // has passed since it was last renewed (so calls cost a write at most
  // every mission_lease / 4); best effort: a failure is logged.
  void KeepLease(Mission& mission);
  // Registers a mission in the listing order (mu_ held).
  void Register(const std::string& key, std::shared_ptr<Mission> mission)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Forgets this server's copy `mission` of `key` (if it is still the one
  // held) and ends its watchers' streams with `reason`.
  void Drop(const std::string& key, const std::shared_ptr<Mission>& mission,
            const absl::Status& reason);
  // Hooks a mission up to the snapshot thread.
  void WatchForSnapshots(Mission& mission);
  // Captures and stores the snapshot of one mission (on the snapshot
  // thread).
  void TakeSnapshot(const std::string& mission_id);
  // Deletes by key; request_key is the tenant's request_id as a key.
  absl::Status DeleteKey(const std::string& key, const std::string& request_key,
                         const std::string& request_id);
  // The memory estimate of a mission of `config`; ResourceExhausted when it
  // is over the per-mission limit.
  absl::StatusOr<std::int64_t> AdmitMemory(const MissionConfig& config) const;
  // What the missions held and being built may need together.
  std::int64_t ReservedBytes() const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // What a mission estimated at `estimate` bytes may keep in its log:
  // the rest of max_mission_memory_bytes (no limit without one).
  std::int64_t LogLimit(std::int64_t estimate) const;

  const RegistryLimits limits_;
  // What missions over one site share (priors, ESDFs, worlds, starting
  // maps, sparse priors), owned here.
  SiteCacheSet caches_;
  MissionStore* const store_;
  mutable absl::Mutex mu_;
  // nullptr while a mission is being built (its id is reserved).
  std::map<std::string, std::shared_ptr<Mission>> missions_ ABSL_GUARDED_BY(mu_);
  // The memory estimate of each mission being built.
  std::map<std::string, std::int64_t> building_bytes_ ABSL_GUARDED_BY(mu_);
  // Creation number -> id: the listing order. Numbers are never reused, so a
  // page token (the last number shown) stays valid when missions go.
  std::map<std::int64_t, std::string> order_ ABSL_GUARDED_BY(mu_);
  std::map<std::string, std::int64_t> number_of_ ABSL_GUARDED_BY(mu_);
  std::int64_t next_number_ ABSL_GUARDED_BY(mu_) = 1;
  mutable absl::Mutex key_mu_;
  mutable std::string page_token_key_ ABSL_GUARDED_BY(key_mu_);
  std::int64_t next_id_ ABSL_GUARDED_BY(mu_) = 1;
  // request_id -> the mission it created (and the creating request's
  // fingerprint) / deleted.
  RequestMemo<std::pair<std::string, std::string>> created_by_request_ ABSL_GUARDED_BY(mu_);
  RequestMemo<std::string> deleted_by_request_ ABSL_GUARDED_BY(mu_);
  // Takeovers in progress (shared store), by key: later callers wait for
  // the first one's result.
  struct Takeover {
    absl::Notification done;
    absl::StatusOr<std::shared_ptr<Mission>> result = absl::UnknownError("not taken over");
  };
  std::map<std::string, std::shared_ptr<Takeover>> takeovers_in_progress_ ABSL_GUARDED_BY(mu_);
  std::int64_t takeovers_ ABSL_GUARDED_BY(mu_) = 0;
  std::int64_t takeovers_from_standby_ ABSL_GUARDED_BY(mu_) = 0;
  // Warm standbys by key (KeepStandbys); KeepStandbys runs on one thread.
  std::map<std::string, std::shared_ptr<Standby>> standbys_ ABSL_GUARDED_BY(mu_);

  // Held while a snapshot is read and written and while a mission is
  // deleted (before mu_), so that a snapshot of a deleted mission never
  // lands on a new one of the same id.
  absl::Mutex snapshot_write_mu_ ABSL_ACQUIRED_BEFORE(mu_);
  // The snapshot thread (running with a store and snapshot_every > 0).
  SnapshotWriter snapshots_;
};

}  // namespace oaipp::server
