#include "server/store/sqlite_store.h"

#include <openssl/rand.h>
#include <sqlite3.h>

#include <deque>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "core/common/status_macros.h"
#include "server/store/sqlite_leases.h"
#include "server/store/sqlite_schema.h"
#include "server/store/sqlite_statement.h"

namespace oaipp::server {
namespace {

using sqlite::SqliteError;
using sqlite::Statement;

absl::Status NoMission(const std::string& id) {
  return absl::NotFoundError(absl::StrCat("store: no mission '", id, "'"));
}

// An append waiting for the group commit that takes it.
struct PendingAppend {
  const std::string* mission_id;
  const LogRecord* record;
  absl::Status status = absl::OkStatus();
  bool done = false;
};

class SqliteStore final : public MissionStore {
 public:
  explicit SqliteStore(sqlite3* db) : db_(db) {}
  ~SqliteStore() override { sqlite3_close(db_); }

  absl::Status Init() {
    absl::MutexLock lock(&mu_);
    return sqlite::OpenSchema(db_);
  }

  absl::StatusOr<std::int64_t> NextMissionNumber() override {
    absl::MutexLock lock(&mu_);
    Statement s(db_,
                "INSERT INTO counters(name, value) VALUES('mission', 1) "
                "ON CONFLICT(name) DO UPDATE SET value = value + 1 RETURNING value");
    OAIPP_RETURN_IF_ERROR(s.prepared("next mission number"));
    const int code = s.Step();
    if (code != SQLITE_ROW) return SqliteError(db_, code, "next mission number");
    const std::int64_t value = s.Int(0);
    if (const int done = s.Step(); done != SQLITE_DONE) {
      return SqliteError(db_, done, "next mission number");
    }
    return value;
  }

  absl::Status CreateMission(const StoredMission& m) override {
    absl::MutexLock lock(&mu_);
    Statement s(db_,
                "INSERT INTO missions(id, spec, request_id, fingerprint, create_time_us) "
                "VALUES(?, ?, ?, ?, ?)");
    OAIPP_RETURN_IF_ERROR(s.prepared("create mission"));
    s.Bind(1, m.id);
    s.Bind(2, m.spec, /*blob=*/true);
    s.Bind(3, m.request_id);
    s.Bind(4, m.fingerprint);
    s.Bind(5, m.create_time_unix_us);
    return s.Done(absl::StrCat("create mission '", m.id, "'"));
  }

  // Group commit: the caller queues its record; the first caller that finds
  // no commit in progress becomes the leader and writes everything queued,
  // in one transaction with one fsync. Callers of different missions
  // therefore share an fsync instead of waiting for each other's.
  absl::Status Append(const std::string& mission_id, const LogRecord& r) override {
    PendingAppend pending{.mission_id = &mission_id, .record = &r};
    std::deque<PendingAppend*> batch;
    {
      absl::MutexLock lock(&queue_mu_);
      queue_.push_back(&pending);
      const auto can_go = [&]() ABSL_SHARED_LOCKS_REQUIRED(queue_mu_) {
        return pending.done || !committing_;
      };
      queue_mu_.Await(absl::Condition(&can_go));
      if (pending.done) return pending.status;
      committing_ = true;
      batch.swap(queue_);
    }
    {
      absl::MutexLock lock(&mu_);
      CommitGroup(batch);
    }
    absl::MutexLock lock(&queue_mu_);
    for (PendingAppend* p : batch) p->done = true;
    committing_ = false;
    return pending.status;
  }

  absl::Status PutSnapshot(const std::string& mission_id, const StoredSnapshot& snap) override {
    absl::MutexLock lock(&mu_);
    return InTransaction("snapshot", [&]() -> absl::Status {
      OAIPP_ASSIGN_OR_RETURN(const std::int64_t epoch, EpochLocked(mission_id));
      if (epoch != snap.epoch) {
        return FencedError(absl::StrCat("snapshot of '", mission_id, "'"), epoch, snap.epoch);
      }
      Statement s(db_,
                  "INSERT INTO snapshots(mission_id, sequence, state, write_time_us) "
                  "VALUES(?, ?, ?, ?) ON CONFLICT(mission_id) DO UPDATE SET "
                  "sequence = excluded.sequence, state = excluded.state, "
                  "write_time_us = excluded.write_time_us "
                  "WHERE excluded.sequence > snapshots.sequence");
      OAIPP_RETURN_IF_ERROR(s.prepared("snapshot"));
      s.Bind(1, mission_id);
      s.Bind(2, snap.sequence);
      s.Bind(3, snap.state, /*blob=*/true);
      s.Bind(4, snap.write_time_unix_us != 0 ? snap.write_time_unix_us : NowUs());
      OAIPP_RETURN_IF_ERROR(s.Done(absl::StrCat("snapshot of '", mission_id, "'")));
      Statement d(db_,
                  "DELETE FROM records WHERE mission_id = ?1 AND sequence <= "
                  "(SELECT sequence FROM snapshots WHERE mission_id = ?1)");
      OAIPP_RETURN_IF_ERROR(d.prepared("snapshot"));
      d.Bind(1, mission_id);
      return d.Done(absl::StrCat("snapshot of '", mission_id, "'"));
    });
  }

  absl::Status DeleteMission(const std::string& mission_id, const std::string& request_id,
                             std::int64_t epoch) override {
    absl::MutexLock lock(&mu_);
    return InTransaction("delete", [&]() -> absl::Status {
      OAIPP_ASSIGN_OR_RETURN(const std::int64_t stored, EpochLocked(mission_id));
      if (stored != epoch) {
        return FencedError(absl::StrCat("delete mission '", mission_id, "'"), stored, epoch);
      }
      Statement s(db_, "DELETE FROM missions WHERE id = ?");
      OAIPP_RETURN_IF_ERROR(s.prepared("delete"));
      s.Bind(1, mission_id);
      OAIPP_RETURN_IF_ERROR(s.Done("delete"));
      if (sqlite3_changes(db_) == 0) return NoMission(mission_id);
      if (request_id.empty()) return absl::OkStatus();
      Statement d(db_,
                  "INSERT OR IGNORE INTO deletions(request_id, mission_id, time_us) "
                  "VALUES(?, ?, ?)");
      OAIPP_RETURN_IF_ERROR(d.prepared("delete"));
      d.Bind(1, request_id);
      d.Bind(2, mission_id);
      d.Bind(3, NowUs());
      return d.Done("delete");
    });
  }

  absl::StatusOr<std::vector<StoredMission>> LoadAll() override {
    absl::MutexLock lock(&mu_);
    // One read transaction: a consistent picture even if a writer of
    // another process were at work.
    OAIPP_RETURN_IF_ERROR(Exec("BEGIN", "load"));
    absl::StatusOr<std::vector<StoredMission>> out = LoadWhere("");
    (void)Exec("COMMIT", "load");
    return out;
  }

  absl::StatusOr<StoredMission> Load(const std::string& mission_id) override {
    absl::MutexLock lock(&mu_);
    OAIPP_RETURN_IF_ERROR(Exec("BEGIN", "load"));
    absl::StatusOr<std::vector<StoredMission>> out = LoadWhere(mission_id);
    (void)Exec("COMMIT", "load");
    if (!out.ok()) return out.status();
    if (out->empty()) return NoMission(mission_id);
    return std::move(out->front());
  }

  absl::StatusOr<StoredMission> Claim(const std::string& mission_id,
                                      std::int64_t have_through) override {
    absl::MutexLock lock(&mu_);
    OAIPP_RETURN_IF_ERROR(Exec("BEGIN IMMEDIATE", "claim"));
    absl::StatusOr<std::vector<StoredMission>> out =
        [&]() -> absl::StatusOr<std::vector<StoredMission>> {
      Statement s(db_, "UPDATE missions SET epoch = epoch + 1 WHERE id = ?");
      OAIPP_RETURN_IF_ERROR(s.prepared("claim"));
      s.Bind(1, mission_id);
      OAIPP_RETURN_IF_ERROR(s.Done("claim"));
      if (sqlite3_changes(db_) == 0) return NoMission(mission_id);
      return LoadWhere(mission_id);
    }();
    if (!out.ok() || out->empty()) {
      (void)Exec("ROLLBACK", "claim");
      return out.ok() ? NoMission(mission_id) : out.status();
    }
    if (absl::Status committed = Exec("COMMIT", "claim"); !committed.ok()) {
      (void)Exec("ROLLBACK", "claim");
      return committed;
    }
    KeepOnlyAfter(out->front(), have_through);  // a local file: nothing to save in the read
    return std::move(out->front());
  }

  absl::StatusOr<std::int64_t> Epoch(const std::string& mission_id) override {
    absl::MutexLock lock(&mu_);
    return EpochLocked(mission_id);
  }

  absl::StatusOr<StoredMission> CreatedBy(const std::string& request_id) override {
    absl::MutexLock lock(&mu_);
    Statement s(db_,
                "SELECT id, request_id, fingerprint, create_time_us, epoch FROM missions "
                "WHERE request_id = ? ORDER BY create_time_us, id LIMIT 1");
    OAIPP_RETURN_IF_ERROR(s.prepared("created by"));
    s.Bind(1, request_id);
    const int code = s.Step();
    if (code == SQLITE_DONE) {
      return absl::NotFoundError("store: no mission created by that request_id");
    }
    if (code != SQLITE_ROW) return SqliteError(db_, code, "created by");
    return StoredMission{.id = s.Bytes(0),
                         .request_id = s.Bytes(1),
                         .fingerprint = s.Bytes(2),
                         .create_time_unix_us = s.Int(3),
                         .epoch = s.Int(4)};
  }

  absl::StatusOr<std::string> DeletedBy(const std::string& request_id) override {
    absl::MutexLock lock(&mu_);
    Statement s(db_, "SELECT mission_id FROM deletions WHERE request_id = ?");
    OAIPP_RETURN_IF_ERROR(s.prepared("deleted by"));
    s.Bind(1, request_id);
    const int code = s.Step();
    if (code == SQLITE_ROW) return s.Bytes(0);
    if (code == SQLITE_DONE) return absl::NotFoundError("store: no deletion by that request_id");
    return SqliteError(db_, code, "deleted by");
  }

  absl::Status ForgetDeletionsBefore(std::int64_t unix_us) override {
    absl::MutexLock lock(&mu_);
    for (const char* sql :
         {"DELETE FROM deletions WHERE time_us < ?", "DELETE FROM leases WHERE until_us < ?",
          "DELETE FROM alive WHERE until_us < ?"}) {
      Statement s(db_, sql);
      OAIPP_RETURN_IF_ERROR(s.prepared("forget deletions"));
      s.Bind(1, unix_us);
      OAIPP_RETURN_IF_ERROR(s.Done("forget deletions"));
    }
    return absl::OkStatus();
  }

  absl::StatusOr<std::vector<MissionListing>> List(const std::string& prefix,
                                                   std::int64_t after_time_us,
                                                   const std::string& after_id,
                                                   int limit) override {
    absl::MutexLock lock(&mu_);
    // Ids are compared as bytes (BINARY); substr and instr count bytes on
    // blobs, so the prefix is matched on the id cast to one.
    Statement s(db_,
                "SELECT id, spec, create_time_us FROM missions "
                "WHERE substr(CAST(id AS BLOB), 1, length(?1)) = ?1 "
                "AND instr(substr(CAST(id AS BLOB), length(?1) + 1), X'2F') = 0 "
                "AND (create_time_us > ?2 OR (create_time_us = ?2 AND id > ?3)) "
                "ORDER BY create_time_us, id LIMIT ?4");
    OAIPP_RETURN_IF_ERROR(s.prepared("list"));
    s.Bind(1, prefix, /*blob=*/true);
    s.Bind(2, after_time_us);
    s.Bind(3, after_id);
    s.Bind(4, static_cast<std::int64_t>(limit));
    std::vector<MissionListing> out;
    int code = SQLITE_ROW;
    while ((code = s.Step()) == SQLITE_ROW) {
      out.push_back({.id = s.Bytes(0), .spec = s.Bytes(1), .create_time_unix_us = s.Int(2)});
    }
    if (code != SQLITE_DONE) return SqliteError(db_, code, "list");
    return out;
  }

  absl::StatusOr<bool> TryLease(const std::string& name, const std::string& holder,
                                std::int64_t now_us, std::int64_t until_us,
                                bool free_if_holder_silent) override {
    absl::MutexLock lock(&mu_);
    return sqlite::TryLease(db_, name, holder, now_us, until_us, free_if_holder_silent);
  }
  absl::StatusOr<std::int64_t> LeaseHolderAliveUntil(const std::string& name) override {
    absl::MutexLock lock(&mu_);
    return sqlite::LeaseHolderAliveUntil(db_, name);
  }
  absl::Status Heartbeat(const std::string& holder, std::int64_t until_us, int ring_id) override {
    absl::MutexLock lock(&mu_);
    return sqlite::Heartbeat(db_, holder, until_us, ring_id);
  }
  absl::StatusOr<StoreView> View(const std::string& lease_prefix, std::int64_t now_us) override {
    absl::MutexLock lock(&mu_);
    OAIPP_RETURN_IF_ERROR(Exec("BEGIN", "view"));
    absl::StatusOr<StoreView> view = sqlite::View(db_, lease_prefix, now_us);
    (void)Exec("COMMIT", "view");
    return view;
  }
  absl::Status Retire(const std::string& holder) override {
    absl::MutexLock lock(&mu_);
    return sqlite::Retire(db_, holder);
  }

  absl::StatusOr<std::vector<std::pair<std::string, std::int64_t>>> IdleSince(
      std::int64_t before_us, int limit) override {
    absl::MutexLock lock(&mu_);
    Statement s(db_,
                "SELECT m.id, m.epoch FROM missions m WHERE m.create_time_us < ?1 "
                "AND NOT EXISTS (SELECT 1 FROM records r WHERE r.mission_id = m.id "
                "AND r.write_time_us >= ?1) "
                "AND NOT EXISTS (SELECT 1 FROM snapshots s WHERE s.mission_id = m.id "
                "AND s.write_time_us >= ?1) "
                "ORDER BY m.create_time_us, m.id LIMIT ?2");
    OAIPP_RETURN_IF_ERROR(s.prepared("idle missions"));
    s.Bind(1, before_us);
    s.Bind(2, static_cast<std::int64_t>(limit));
    std::vector<std::pair<std::string, std::int64_t>> out;
    int code = SQLITE_ROW;
    while ((code = s.Step()) == SQLITE_ROW) out.emplace_back(s.Bytes(0), s.Int(1));
    if (code != SQLITE_DONE) return SqliteError(db_, code, "idle missions");
    return out;
  }

  absl::StatusOr<std::string> SigningKey() override {
    absl::MutexLock lock(&mu_);
    std::string key;
    OAIPP_RETURN_IF_ERROR(InTransaction("signing key", [&]() -> absl::Status {
      Statement read(db_, "SELECT value FROM secrets WHERE name = 'page_tokens'");
      OAIPP_RETURN_IF_ERROR(read.prepared("signing key"));
      const int code = read.Step();
      if (code == SQLITE_ROW) {
        key = read.Bytes(0);
        return absl::OkStatus();
      }
      if (code != SQLITE_DONE) return SqliteError(db_, code, "signing key");
      key.assign(32, '\0');
      if (RAND_bytes(reinterpret_cast<unsigned char*>(key.data()), 32) != 1) {
        return absl::InternalError("signing key: no random bytes");
      }
      Statement write(db_, "INSERT INTO secrets(name, value) VALUES('page_tokens', ?)");
      OAIPP_RETURN_IF_ERROR(write.prepared("signing key"));
      write.Bind(1, key, /*blob=*/true);
      return write.Done("signing key");
    }));
    return key;
  }

  // A real write (one small durable transaction), so that a full or lost
  // disk shows.
  absl::Status Health() override {
    absl::MutexLock lock(&mu_);
    return Exec(
        "INSERT INTO counters(name, value) VALUES('health', 0) "
        "ON CONFLICT(name) DO UPDATE SET value = value + 1",
        "health");
  }

 private:
  static std::int64_t NowUs() { return absl::ToUnixMicros(absl::Now()); }

  // Writes a group of appends in one transaction. Each record is inserted
  // under its own savepoint, so one refused record (a duplicate sequence)
  // does not take the others with it; a failed commit fails them all.
  void CommitGroup(const std::deque<PendingAppend*>& batch) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    absl::Status begun = Exec("BEGIN IMMEDIATE", "append");
    if (!begun.ok()) {
      for (PendingAppend* p : batch) p->status = begun;
      return;
    }
    const std::int64_t now = NowUs();
    for (PendingAppend* p : batch) {
      if (absl::Status s = Exec("SAVEPOINT one", "append"); !s.ok()) {
        p->status = s;
        continue;
      }
      p->status = InsertRecord(*p->mission_id, *p->record, now);
      if (!p->status.ok()) (void)Exec("ROLLBACK TO one", "append");
      (void)Exec("RELEASE one", "append");
    }
    if (absl::Status committed = Exec("COMMIT", "append"); !committed.ok()) {
      (void)Exec("ROLLBACK", "append");
      for (PendingAppend* p : batch) {
        if (p->status.ok()) p->status = committed;
      }
    }
  }

  absl::Status InsertRecord(const std::string& mission_id, const LogRecord& r, std::int64_t now)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    const std::string what = absl::StrCat("append ", mission_id, "#", r.sequence);
    if (r.sequence < 1) {
      return absl::InvalidArgumentError(absl::StrCat("store: ", what, ": sequences start at 1"));
    }
    if (absl::StatusOr<std::int64_t> epoch = EpochLocked(mission_id); !epoch.ok()) {
      return epoch.status();
    } else if (*epoch != r.epoch) {
      return FencedError(what, *epoch, r.epoch);
    }
    {
      // A record a snapshot covers is gone from the table, so a second one
      // there would not collide with it: refuse it here.
      Statement snap(db_, "SELECT sequence FROM snapshots WHERE mission_id = ?");
      OAIPP_RETURN_IF_ERROR(snap.prepared("append"));
      snap.Bind(1, mission_id);
      if (snap.Step() == SQLITE_ROW && r.sequence <= snap.Int(0)) {
        return absl::AlreadyExistsError(
            absl::StrCat("store: ", what, ": a snapshot already covers that sequence"));
      }
    }
    Statement s(db_,
                "INSERT INTO records(mission_id, sequence, kind, payload, request_id, "
                "fingerprint, result, planner_state, write_time_us) "
                "VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?)");
    OAIPP_RETURN_IF_ERROR(s.prepared("append"));
    s.Bind(1, mission_id);
    s.Bind(2, r.sequence);
    s.Bind(3, static_cast<std::int64_t>(r.kind));
    s.Bind(4, r.payload, /*blob=*/true);
    s.Bind(5, r.request_id);
    s.Bind(6, r.fingerprint);
    s.Bind(7, r.result, /*blob=*/true);
    s.Bind(8, r.planner_state, /*blob=*/true);
    s.Bind(9, r.write_time_unix_us != 0 ? r.write_time_unix_us : now);
    absl::Status status = s.Done(what);
    if (status.code() != absl::StatusCode::kAlreadyExists) return status;
    // A record of a mission that is not there breaks the foreign key.
    if (!Exists(mission_id)) return NoMission(mission_id);
    // The same request at the same place: a retry of a write whose outcome
    // the writer could not know. Anything else is a second writer.
    Statement q(db_,
                "SELECT payload, request_id, fingerprint FROM records "
                "WHERE mission_id = ? AND sequence = ?");
    OAIPP_RETURN_IF_ERROR(q.prepared("append"));
    q.Bind(1, mission_id);
    q.Bind(2, r.sequence);
    if (q.Step() == SQLITE_ROW && q.Bytes(0) == r.payload && q.Bytes(1) == r.request_id &&
        q.Bytes(2) == r.fingerprint) {
      return absl::OkStatus();
    }
    return status;
  }

  // Missions (all, or the one with id `only`) with their snapshot and the
  // records after it.
  absl::StatusOr<std::vector<StoredMission>> LoadWhere(const std::string& only)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    std::vector<StoredMission> out;
    {
      Statement s(db_, only.empty()
                           ? "SELECT id, spec, request_id, fingerprint, create_time_us, epoch "
                             "FROM missions ORDER BY create_time_us, id"
                           : "SELECT id, spec, request_id, fingerprint, create_time_us, epoch "
                             "FROM missions WHERE id = ?");
      OAIPP_RETURN_IF_ERROR(s.prepared("load missions"));
      if (!only.empty()) s.Bind(1, only);
      int code;
      while ((code = s.Step()) == SQLITE_ROW) {
        out.push_back({.id = s.Bytes(0),
                       .spec = s.Bytes(1),
                       .request_id = s.Bytes(2),
                       .fingerprint = s.Bytes(3),
                       .create_time_unix_us = s.Int(4),
                       .epoch = s.Int(5)});
      }
      if (code != SQLITE_DONE) return SqliteError(db_, code, "load missions");
    }
    for (StoredMission& m : out) {
      Statement snap(db_,
                     "SELECT sequence, state, write_time_us FROM snapshots WHERE mission_id = ?");
      OAIPP_RETURN_IF_ERROR(snap.prepared("load snapshot"));
      snap.Bind(1, m.id);
      if (const int code = snap.Step(); code == SQLITE_ROW) {
        m.snapshot = StoredSnapshot{
            .sequence = snap.Int(0), .state = snap.Bytes(1), .write_time_unix_us = snap.Int(2)};
      } else if (code != SQLITE_DONE) {
        return SqliteError(db_, code, "load snapshot");
      }
      Statement s(db_,
                  "SELECT sequence, kind, payload, request_id, fingerprint, result, planner_state, "
                  "write_time_us FROM records WHERE mission_id = ? AND sequence > ? "
                  "ORDER BY sequence");
      OAIPP_RETURN_IF_ERROR(s.prepared("load records"));
      s.Bind(1, m.id);
      s.Bind(2, m.snapshot.has_value() ? m.snapshot->sequence : std::int64_t{0});
      int code;
      while ((code = s.Step()) == SQLITE_ROW) {
        m.log.push_back({.sequence = s.Int(0),
                         .kind = static_cast<RecordKind>(s.Int(1)),
                         .payload = s.Bytes(2),
                         .request_id = s.Bytes(3),
                         .fingerprint = s.Bytes(4),
                         .result = s.Bytes(5),
                         .planner_state = s.Bytes(6),
                         .write_time_unix_us = s.Int(7)});
      }
      if (code != SQLITE_DONE) return SqliteError(db_, code, "load records");
    }
    return out;
  }

  template <typename Body>
  absl::Status InTransaction(absl::string_view what, Body body) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    OAIPP_RETURN_IF_ERROR(Exec("BEGIN IMMEDIATE", what));
    absl::Status status = body();
    if (!status.ok()) {
      (void)Exec("ROLLBACK", what);
      return status;
    }
    if (status = Exec("COMMIT", what); !status.ok()) (void)Exec("ROLLBACK", what);
    return status;
  }
  absl::Status Exec(const char* sql, absl::string_view what) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    return sqlite::Exec(db_, sql, what);
  }
  absl::StatusOr<std::int64_t> EpochLocked(const std::string& mission_id)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    Statement s(db_, "SELECT epoch FROM missions WHERE id = ?");
    OAIPP_RETURN_IF_ERROR(s.prepared("epoch"));
    s.Bind(1, mission_id);
    const int code = s.Step();
    if (code == SQLITE_ROW) return s.Int(0);
    if (code == SQLITE_DONE) return NoMission(mission_id);
    return SqliteError(db_, code, "epoch");
  }
  bool Exists(const std::string& mission_id) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    Statement s(db_, "SELECT 1 FROM missions WHERE id = ?");
    if (!s.prepared("exists").ok()) return false;
    s.Bind(1, mission_id);
    return s.Step() == SQLITE_ROW;
  }

  absl::Mutex mu_;  // one connection, one transaction at a time
  sqlite3* db_ ABSL_GUARDED_BY(mu_);

  absl::Mutex queue_mu_;
  std::deque<PendingAppend*> queue_ ABSL_GUARDED_BY(queue_mu_);
  bool committing_ ABSL_GUARDED_BY(queue_mu_) = false;  // a leader is writing a group
};

}  // namespace

absl::StatusOr<std::unique_ptr<MissionStore>> OpenSqliteStore(const std::string& path) {
  sqlite3* db = nullptr;
  const int code =
      sqlite3_open_v2(path.c_str(), &db,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX, nullptr);
  if (code != SQLITE_OK) {
    absl::Status status = absl::UnavailableError(
        absl::StrCat("store: cannot open '", path, "': ", db ? sqlite3_errmsg(db) : "no memory"));
    sqlite3_close(db);
    return status;
  }
  sqlite3_busy_timeout(db, 5000);
  auto store = std::make_unique<SqliteStore>(db);
  OAIPP_RETURN_IF_ERROR(store->Init());
  return store;
}

}  // namespace oaipp::server
