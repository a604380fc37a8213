// Opening the SQLite store's file: its settings, and its tables created or
// brought up to this server's schema (sqlite_schema.h).
#include <cstdint>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"
#include "server/store/sqlite_schema.h"
#include "server/store/sqlite_statement.h"

namespace oaipp::server::sqlite {
namespace {

// The servers' ring ids came after the table of the servers alive (whose
// rows are heartbeats, not data): the column is added where it is missing.
absl::Status AddRingIds(sqlite3* db) {
  Statement s(db, "SELECT 1 FROM pragma_table_info('alive') WHERE name = 'ring_id'");
  OAIPP_RETURN_IF_ERROR(s.prepared("schema"));
  if (s.Step() == SQLITE_ROW) return absl::OkStatus();
  return Exec(db, "ALTER TABLE alive ADD COLUMN ring_id INTEGER NOT NULL DEFAULT 0",
              "schema upgrade");
}

}  // namespace

absl::Status OpenSchema(sqlite3* db) {
  OAIPP_RETURN_IF_ERROR(Exec(db, "PRAGMA journal_mode=WAL", "journal mode"));
  OAIPP_RETURN_IF_ERROR(Exec(db, "PRAGMA synchronous=FULL", "synchronous"));
  OAIPP_RETURN_IF_ERROR(Exec(db, "PRAGMA foreign_keys=ON", "foreign keys"));
  std::int64_t version = 0;
  {
    Statement s(db, "PRAGMA user_version");
    OAIPP_RETURN_IF_ERROR(s.prepared("schema version"));
    if (s.Step() == SQLITE_ROW) version = s.Int(0);
  }
  if (version > kSchemaVersion) {
    return absl::FailedPreconditionError(
        absl::StrCat("store: the file has schema version ", version, "; this server reads up to ",
                     kSchemaVersion, " (a newer server wrote it)"));
  }
  bool had_missions = false;
  {
    Statement s(db, "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'missions'");
    OAIPP_RETURN_IF_ERROR(s.prepared("schema"));
    had_missions = s.Step() == SQLITE_ROW;
  }
  if (version == kSchemaVersion) {
    OAIPP_RETURN_IF_ERROR(Exec(db, kSchema, "schema"));
    return AddRingIds(db);
  }
  OAIPP_RETURN_IF_ERROR(Exec(db, "BEGIN IMMEDIATE", "schema"));
  absl::Status status = [&]() -> absl::Status {
    // A file of version 0 with tables is a version 1 file (it predates
    // the version number).
    if (had_missions && version <= 1) {
      OAIPP_RETURN_IF_ERROR(Exec(db, kFromVersion1, "schema upgrade"));
    }
    if (had_missions && version <= 2) {
      OAIPP_RETURN_IF_ERROR(Exec(db, kFromVersion2, "schema upgrade"));
    }
    OAIPP_RETURN_IF_ERROR(Exec(db, kSchema, "schema"));
    return Exec(db, absl::StrCat("PRAGMA user_version = ", kSchemaVersion).c_str(), "schema");
  }();
  if (!status.ok()) {
    (void)Exec(db, "ROLLBACK", "schema");
    return status;
  }
  OAIPP_RETURN_IF_ERROR(Exec(db, "COMMIT", "schema"));
  return AddRingIds(db);
}

}  // namespace oaipp::server::sqlite
