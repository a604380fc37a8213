#include "server/store/sqlite_store.h"

#include <sqlite3.h>

#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "core/common/status_macros.h"

namespace oaipp::server {
namespace {

constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS counters(
  name TEXT PRIMARY KEY,
  value INTEGER NOT NULL);
CREATE TABLE IF NOT EXISTS missions(
  id TEXT PRIMARY KEY,
  spec BLOB NOT NULL,
  request_id TEXT NOT NULL,
  fingerprint TEXT NOT NULL,
  create_time_us INTEGER NOT NULL);
CREATE TABLE IF NOT EXISTS records(
  mission_id TEXT NOT NULL REFERENCES missions(id) ON DELETE CASCADE,
  sequence INTEGER NOT NULL,
  kind INTEGER NOT NULL,
  payload BLOB NOT NULL,
  request_id TEXT NOT NULL,
  fingerprint TEXT NOT NULL,
  result BLOB NOT NULL,
  planner_state BLOB NOT NULL,
  PRIMARY KEY(mission_id, sequence));
CREATE TABLE IF NOT EXISTS deletions(
  request_id TEXT PRIMARY KEY,
  mission_id TEXT NOT NULL);
)sql";

// The status for a failed SQLite call: a full disk is ResourceExhausted, a
// violated key AlreadyExists, anything else Unavailable (the store, not the
// request, is at fault).
absl::Status SqliteError(sqlite3* db, int code, absl::string_view what) {
  const std::string message = absl::StrCat("store: ", what, ": ", sqlite3_errmsg(db));
  switch (code & 0xff) {
    case SQLITE_FULL:
      return absl::ResourceExhaustedError(message);
    case SQLITE_CONSTRAINT:
      return absl::AlreadyExistsError(message);
    default:
      return absl::UnavailableError(message);
  }
}

// A prepared statement, finalized when it goes out of scope.
class Statement {
 public:
  Statement(sqlite3* db, const char* sql) : db_(db) {
    code_ = sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr);
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  [[nodiscard]] absl::Status prepared(absl::string_view what) const {
    return code_ == SQLITE_OK ? absl::OkStatus() : SqliteError(db_, code_, what);
  }
  void Bind(int i, const std::string& bytes, bool blob = false) {
    if (blob) {
      sqlite3_bind_blob(stmt_, i, bytes.data(), static_cast<int>(bytes.size()), SQLITE_TRANSIENT);
    } else {
      sqlite3_bind_text(stmt_, i, bytes.data(), static_cast<int>(bytes.size()), SQLITE_TRANSIENT);
    }
  }
  void Bind(int i, std::int64_t value) { sqlite3_bind_int64(stmt_, i, value); }
  // SQLITE_ROW, SQLITE_DONE or an error code.
  int Step() { return sqlite3_step(stmt_); }
  [[nodiscard]] std::string Bytes(int column) const {
    const void* data = sqlite3_column_blob(stmt_, column);
    const int size = sqlite3_column_bytes(stmt_, column);
    return data == nullptr ? std::string() : std::string(static_cast<const char*>(data), size);
  }
  [[nodiscard]] std::int64_t Int(int column) const { return sqlite3_column_int64(stmt_, column); }

 private:
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
  int code_ = SQLITE_OK;
};

class SqliteStore final : public MissionStore {
 public:
  explicit SqliteStore(sqlite3* db) : db_(db) {}
  ~SqliteStore() override { sqlite3_close(db_); }

  absl::Status Init() {
    absl::MutexLock lock(&mu_);
    OAIPP_RETURN_IF_ERROR(Exec("PRAGMA journal_mode=WAL", "journal mode"));
    OAIPP_RETURN_IF_ERROR(Exec("PRAGMA synchronous=FULL", "synchronous"));
    OAIPP_RETURN_IF_ERROR(Exec("PRAGMA foreign_keys=ON", "foreign keys"));
    return Exec(kSchema, "schema");
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
    return Done(s, absl::StrCat("create mission '", m.id, "'"));
  }

  absl::Status Append(const std::string& mission_id, const LogRecord& r) override {
    absl::MutexLock lock(&mu_);
    Statement s(db_,
                "INSERT INTO records(mission_id, sequence, kind, payload, request_id, "
                "fingerprint, result, planner_state) VALUES(?, ?, ?, ?, ?, ?, ?, ?)");
    OAIPP_RETURN_IF_ERROR(s.prepared("append"));
    s.Bind(1, mission_id);
    s.Bind(2, r.sequence);
    s.Bind(3, static_cast<std::int64_t>(r.kind));
    s.Bind(4, r.payload, /*blob=*/true);
    s.Bind(5, r.request_id);
    s.Bind(6, r.fingerprint);
    s.Bind(7, r.result, /*blob=*/true);
    s.Bind(8, r.planner_state, /*blob=*/true);
    absl::Status status = Done(s, absl::StrCat("append ", mission_id, "#", r.sequence));
    // A record of a mission that is not there breaks the foreign key.
    if (status.code() == absl::StatusCode::kAlreadyExists && !Exists(mission_id)) {
      return absl::NotFoundError(absl::StrCat("store: no mission '", mission_id, "'"));
    }
    return status;
  }

  absl::Status DeleteMission(const std::string& mission_id,
                             const std::string& request_id) override {
    absl::MutexLock lock(&mu_);
    OAIPP_RETURN_IF_ERROR(Exec("BEGIN IMMEDIATE", "delete"));
    absl::Status status = [&]() -> absl::Status {
      Statement s(db_, "DELETE FROM missions WHERE id = ?");
      OAIPP_RETURN_IF_ERROR(s.prepared("delete"));
      s.Bind(1, mission_id);
      OAIPP_RETURN_IF_ERROR(Done(s, "delete"));
      if (sqlite3_changes(db_) == 0) {
        return absl::NotFoundError(absl::StrCat("store: no mission '", mission_id, "'"));
      }
      if (request_id.empty()) return absl::OkStatus();
      Statement d(db_, "INSERT OR IGNORE INTO deletions(request_id, mission_id) VALUES(?, ?)");
      OAIPP_RETURN_IF_ERROR(d.prepared("delete"));
      d.Bind(1, request_id);
      d.Bind(2, mission_id);
      return Done(d, "delete");
    }();
    if (!status.ok()) {
      (void)Exec("ROLLBACK", "delete");
      return status;
    }
    return Exec("COMMIT", "delete");
  }

  absl::StatusOr<std::vector<StoredMission>> LoadAll() override {
    absl::MutexLock lock(&mu_);
    std::vector<StoredMission> out;
    {
      Statement s(db_,
                  "SELECT id, spec, request_id, fingerprint, create_time_us FROM missions "
                  "ORDER BY create_time_us, id");
      OAIPP_RETURN_IF_ERROR(s.prepared("load missions"));
      int code;
      while ((code = s.Step()) == SQLITE_ROW) {
        out.push_back({.id = s.Bytes(0),
                       .spec = s.Bytes(1),
                       .request_id = s.Bytes(2),
                       .fingerprint = s.Bytes(3),
                       .create_time_unix_us = s.Int(4)});
      }
      if (code != SQLITE_DONE) return SqliteError(db_, code, "load missions");
    }
    for (StoredMission& m : out) {
      Statement s(db_,
                  "SELECT sequence, kind, payload, request_id, fingerprint, result, planner_state "
                  "FROM records WHERE mission_id = ? ORDER BY sequence");
      OAIPP_RETURN_IF_ERROR(s.prepared("load records"));
      s.Bind(1, m.id);
      int code;
      while ((code = s.Step()) == SQLITE_ROW) {
        m.log.push_back({.sequence = s.Int(0),
                         .kind = static_cast<RecordKind>(s.Int(1)),
                         .payload = s.Bytes(2),
                         .request_id = s.Bytes(3),
                         .fingerprint = s.Bytes(4),
                         .result = s.Bytes(5),
                         .planner_state = s.Bytes(6)});
      }
      if (code != SQLITE_DONE) return SqliteError(db_, code, "load records");
    }
    return out;
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
  absl::Status Exec(const char* sql, absl::string_view what) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    const int code = sqlite3_exec(db_, sql, nullptr, nullptr, nullptr);
    return code == SQLITE_OK ? absl::OkStatus() : SqliteError(db_, code, what);
  }
  absl::Status Done(Statement& s, absl::string_view what) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    const int code = s.Step();
    return code == SQLITE_DONE ? absl::OkStatus() : SqliteError(db_, code, what);
  }
  bool Exists(const std::string& mission_id) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    Statement s(db_, "SELECT 1 FROM missions WHERE id = ?");
    if (!s.prepared("exists").ok()) return false;
    s.Bind(1, mission_id);
    return s.Step() == SQLITE_ROW;
  }

  absl::Mutex mu_;  // one connection, one writer at a time
  sqlite3* db_ ABSL_GUARDED_BY(mu_);
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
