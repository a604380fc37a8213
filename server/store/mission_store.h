// Where missions live between restarts: a mission is its log (the spec at
// creation, then every applied change in order, each with a per-mission
// sequence number) plus the request_id records that let a retry after a
// restart be answered once (docs/storage.md). A snapshot (the mission's
// state after some record, as bytes the server writes) lets recovery skip
// the records it covers; the store then drops them, so a mission takes a
// snapshot and a short tail, however long it runs.
//
// A MissionStore only stores and returns bytes: the records hold the API's
// own messages (serialized protobuf), so the server that reads them back
// converts them with api/ exactly as it converted the original calls.
// Appends are conditional: (mission, sequence) is unique, so a record is
// never written twice and a writer that lost track is refused.
//
// Ownership: each mission has an epoch, kFirstEpoch when it is created.
// Servers that share a store (a cluster on PostgreSQL) take a mission over
// with Claim, which raises the epoch; every write states the epoch its
// writer holds, and a write from an older epoch (a server that lost the
// mission without knowing it) is refused with kFenced. A single server
// never claims, so its writes all carry kFirstEpoch.
//
// Every method may be called from many threads at once.
//
//   OAIPP_ASSIGN_OR_RETURN(std::unique_ptr<MissionStore> store, OpenSqliteStore("data"));
//   OAIPP_RETURN_IF_ERROR(store->CreateMission(created));
//   OAIPP_RETURN_IF_ERROR(store->Append("m-000001", record));   // durable before the ack
//   OAIPP_ASSIGN_OR_RETURN(std::vector<StoredMission> all, store->LoadAll());
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"

namespace oaipp::server {

// The epoch a mission has when it is created.
inline constexpr std::int64_t kFirstEpoch = 1;

// What a log record holds.
enum class RecordKind : int {
  kObstacles = 1,    // payload: v1::UpdateObstaclesRequest
  kMeasurement = 2,  // payload: v1::AddMeasurementRequest
  kPlan = 3,         // payload: v1::PlanPathRequest; result: PlanPathResponse; planner_state
  kTeam = 4,         // payload: v1::RemoveTeamMemberRequest
};

struct LogRecord {
  std::int64_t sequence = 0;  // 1, 2, ... within the mission
  RecordKind kind = RecordKind::kObstacles;
  std::string payload = {};      // the request as applied (serialized)
  std::string request_id = {};   // empty when the caller sent none
  std::string fingerprint = {};  // of the request, to tell a retry from a reuse
  std::string result = {};       // the first answer (serialized response), where replay
                                 // cannot recompute it
  // The planner's state after this record (kPlan), as Planner::SaveState
  // gives it; empty when the planner keeps none.
  std::string planner_state = {};
  std::int64_t write_time_unix_us = 0;  // when it was written (set by the writer)
  // The ownership epoch the writer holds (not stored: checked).
  std::int64_t epoch = kFirstEpoch;
};

// A mission's state after record `sequence` (the server's own encoding).
struct StoredSnapshot {
  std::int64_t sequence = 0;
  std::string state = {};
  std::int64_t write_time_unix_us = 0;
  std::int64_t epoch = kFirstEpoch;  // the writer's, as for LogRecord
};

struct StoredMission {
  std::string id = {};
  std::string spec = {};  // v1::MissionSpec with every default filled in (serialized)
  std::string request_id = {};
  std::string fingerprint = {};
  std::int64_t create_time_unix_us = 0;
  // The ownership epoch (CreateMission stores kFirstEpoch whatever this says).
  std::int64_t epoch = kFirstEpoch;
  // The latest snapshot, if any; `log` then holds only the records after it.
  std::optional<StoredSnapshot> snapshot = std::nullopt;
  std::vector<LogRecord> log = {};  // by sequence
};

// One line of a listing: what the store knows of a mission without reading
// its log.
struct MissionListing {
  std::string id = {};
  std::string spec = {};
  std::int64_t create_time_unix_us = 0;
};

// `m` as Load gave it, less what a reader that holds the mission through
// record `have_through` has already: the snapshot when it covers no later
// record, and the records up to have_through (MissionStore::Claim).
inline void KeepOnlyAfter(StoredMission& m, std::int64_t have_through) {
  if (have_through <= 0) return;
  if (m.snapshot.has_value() && m.snapshot->sequence <= have_through) m.snapshot.reset();
  std::erase_if(m.log, [&](const LogRecord& r) { return r.sequence <= have_through; });
}

// MissionStore::View.
struct StoreView {
  struct Alive {
    std::string holder;
    int ring_id = 0;
  };
  struct Held {
    std::string mission_id;
    std::string holder;
    bool holder_alive = false;
    int holder_ring_id = 0;
    std::int64_t last_sequence = 0;
  };
  std::vector<Alive> alive;
  std::vector<Held> held;
};

class MissionStore {
 public:
  virtual ~MissionStore() = default;

  // A number for a server-assigned mission id, never returned twice, also
  // across restarts. Unavailable when the store cannot be written.
  [[nodiscard]] virtual absl::StatusOr<std::int64_t> NextMissionNumber() = 0;
  // The mission's spec, durably. AlreadyExists when the id is taken.
  [[nodiscard]] virtual absl::Status CreateMission(const StoredMission& mission) = 0;
  // One record, durably, after those before it. When the mission already
  // has `record.sequence`: OK if the stored record is the same request
  // (payload, request_id and fingerprint: a retry of a write whose outcome
  // was in doubt), AlreadyExists otherwise. NotFound for an unknown mission.
  // Unavailable (ResourceExhausted for a full disk) when the store cannot
  // be written; the record is then not stored, unless the status carries
  // the payload kInDoubt (the connection was lost while committing).
  // Aborted with the payload kFenced when record.epoch is not the mission's
  // epoch (nothing stored).
  [[nodiscard]] virtual absl::Status Append(const std::string& mission_id,
                                            const LogRecord& record) = 0;
  // Replaces the mission's snapshot with a later one and drops the records
  // it covers. A snapshot older than the stored one is ignored (OK).
  // NotFound for an unknown mission; Aborted + kFenced from an old epoch.
  [[nodiscard]] virtual absl::Status PutSnapshot(const std::string& mission_id,
                                                 const StoredSnapshot& snapshot) = 0;
  // Removes the mission, its records and snapshot; remembers request_id (if
  // any) as having deleted it. NotFound for an unknown mission; Aborted +
  // kFenced when `epoch` is not the mission's.
  [[nodiscard]] virtual absl::Status DeleteMission(const std::string& mission_id,
                                                   const std::string& request_id,
                                                   std::int64_t epoch) = 0;
  // Takes the mission over: raises its epoch by one and returns the
  // mission as Load gives it, read after the raise in the same transaction,
  // with `epoch` the new one. From then on, writes of earlier epochs are
  // refused, so what was returned is all a previous owner will ever have
  // written. NotFound for an unknown mission.
  // have_through > 0: the caller already holds the mission as a Load gave
  // it, through record have_through; what it holds is left out
  // (KeepOnlyAfter): the snapshot unless a later one was stored since, and
  // the records up to have_through. Snapshots are megabytes.
  [[nodiscard]] virtual absl::StatusOr<StoredMission> Claim(const std::string& mission_id,
                                                            std::int64_t have_through) = 0;
  // The mission's current epoch (one cheap read). NotFound for an unknown
  // mission.
  [[nodiscard]] virtual absl::StatusOr<std::int64_t> Epoch(const std::string& mission_id) = 0;
  // The mission a CreateMission with `request_id` made (its id,
  // request_id, fingerprint, creation time and epoch; spec, snapshot and log
  // left empty), or NotFound. For servers that share a store: a retry of a
  // create may reach another server than the first attempt.
  [[nodiscard]] virtual absl::StatusOr<StoredMission> CreatedBy(const std::string& request_id) = 0;
  // Every mission: its latest snapshot and the records after it.
  [[nodiscard]] virtual absl::StatusOr<std::vector<StoredMission>> LoadAll() = 0;
  // One mission, as LoadAll gives it. NotFound for an unknown mission.
  [[nodiscard]] virtual absl::StatusOr<StoredMission> Load(const std::string& mission_id) = 0;
  // As Load, less what a reader holding the mission through record
  // `have_through` has already (KeepOnlyAfter, as Claim leaves it out), and
  // without taking the mission: how a warm standby follows a mission that
  // another server holds. A store may skip reading a snapshot it leaves out.
  [[nodiscard]] virtual absl::StatusOr<StoredMission> LoadAfter(const std::string& mission_id,
                                                                std::int64_t have_through) {
    absl::StatusOr<StoredMission> m = Load(mission_id);
    if (m.ok()) KeepOnlyAfter(*m, have_through);
    return m;
  }
  // The mission a request_id deleted, or NotFound.
  [[nodiscard]] virtual absl::StatusOr<std::string> DeletedBy(const std::string& request_id) = 0;
  // Forgets the request_ids of deletions made before `unix_us`, and the
  // leases and heartbeats that lapsed before it (retention).
  [[nodiscard]] virtual absl::Status ForgetDeletionsBefore(std::int64_t unix_us) = 0;
  // OK while the store can be written (it writes to find out).
  [[nodiscard]] virtual absl::Status Health() = 0;
  // The missions whose ids start with `prefix` and hold no '/' after it, in
  // creation order (create time, then id bytewise), after the one created
  // at `after_time_us` with id `after_id` (0 and "": from the first), at
  // most `limit`.
  [[nodiscard]] virtual absl::StatusOr<std::vector<MissionListing>> List(
      const std::string& prefix, std::int64_t after_time_us, const std::string& after_id,
      int limit) = 0;
  // The lease `name` for `holder` until `until_us`, when at `now_us` it is
  // free (never taken, expired, or `holder`'s own; with
  // `free_if_holder_silent`, also when its holder is not alive, see
  // Heartbeat): true when `holder` holds it afterwards. How servers sharing
  // the store agree which one of them does a periodic job (retention) and
  // which one serves a mission; the times are the callers' clocks.
  [[nodiscard]] virtual absl::StatusOr<bool> TryLease(const std::string& name,
                                                      const std::string& holder,
                                                      std::int64_t now_us, std::int64_t until_us,
                                                      bool free_if_holder_silent) = 0;
  // Until when the holder of lease `name` said it is alive (Heartbeat; unix
  // microseconds, its clock), or 0 when nobody holds the lease or its
  // holder never said so or retired. A server waiting for a lease reads
  // this to tell a holder that missed heartbeats from a live one.
  [[nodiscard]] virtual absl::StatusOr<std::int64_t> LeaseHolderAliveUntil(
      const std::string& name) = 0;
  // `holder` is alive until `until_us` (its clock): a server sharing the
  // store says so every fraction of that time. A holder that never said so,
  // whose time has passed, or that retired is not alive. ring_id: its id on
  // the proxies' ring (--ring_id; 0: none), for the others' View.
  [[nodiscard]] virtual absl::Status Heartbeat(const std::string& holder, std::int64_t until_us,
                                               int ring_id) = 0;
  // What a server of a cluster sees of the others at `now_us`: the live
  // holders (Heartbeat) with their ring ids, and every mission with a lease
  // (named `lease_prefix` and the mission id in lower-case hex), expired or
  // not (a live holder still has the mission in memory; a dead one's waits
  // for a takeover), with its holder, whether that holder is alive, its
  // ring id, and the last sequence stored for the mission (its last
  // record's, or its snapshot's). Unimplemented for a store that cannot
  // tell.
  [[nodiscard]] virtual absl::StatusOr<StoreView> View(const std::string& lease_prefix,
                                                       std::int64_t now_us) {
    (void)lease_prefix;
    (void)now_us;
    return absl::UnimplementedError("this store keeps no view of the servers sharing it");
  }
  // `holder` stops: it is no longer alive and holds no lease.
  [[nodiscard]] virtual absl::Status Retire(const std::string& holder) = 0;
  // Missions nothing was written to since `before_us` (created, and their
  // records and snapshot written, before it), with their epochs, oldest
  // first, at most `limit`.
  [[nodiscard]] virtual absl::StatusOr<std::vector<std::pair<std::string, std::int64_t>>> IdleSince(
      std::int64_t before_us, int limit) = 0;
  // 32 random bytes made the first time any server asks and kept in the
  // store, the same for every server that shares it: what they sign page
  // tokens with.
  [[nodiscard]] virtual absl::StatusOr<std::string> SigningKey() = 0;
};

// The status payload (type URL) an Append error carries when the record may
// or may not have been stored: the writer must read the mission back before
// it writes again.
inline constexpr char kInDoubt[] = "oaipp.store/in-doubt";

// The status payload (type URL) of a write refused because another server
// has taken the mission over since the writer got it: the writer must drop
// its copy of the mission.
inline constexpr char kFenced[] = "oaipp.store/fenced";

// The refusal of a write from epoch `writer` to a mission now at `stored`.
[[nodiscard]] inline absl::Status FencedError(absl::string_view what, std::int64_t stored,
                                              std::int64_t writer) {
  absl::Status status = absl::AbortedError(
      absl::StrCat("store: ", what, ": the mission was taken over by another server (epoch ",
                   stored, ", this writer holds ", writer, ")"));
  status.SetPayload(kFenced, absl::Cord("1"));
  return status;
}

}  // namespace oaipp::server
