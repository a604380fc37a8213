#include "server/store/sqlite_leases.h"

#include "core/common/status_macros.h"
#include "server/store/sqlite_statement.h"

namespace oaipp::server::sqlite {

absl::StatusOr<bool> TryLease(sqlite3* db, const std::string& name, const std::string& holder,
                              std::int64_t now_us, std::int64_t until_us,
                              bool free_if_holder_silent) {
  // Taken or renewed only when free: expired, the asker's own, or (when
  // asked) held by a holder that is not alive.
  Statement s(db,
              "INSERT INTO leases(name, holder, until_us) VALUES(?1, ?2, ?4) "
              "ON CONFLICT(name) DO UPDATE SET holder = excluded.holder, "
              "until_us = excluded.until_us WHERE leases.until_us < ?3 "
              "OR leases.holder = excluded.holder OR (?5 AND NOT EXISTS "
              "(SELECT 1 FROM alive a WHERE a.holder = leases.holder AND a.until_us >= ?3)) "
              "RETURNING holder");
  OAIPP_RETURN_IF_ERROR(s.prepared("lease"));
  s.Bind(1, name);
  s.Bind(2, holder);
  s.Bind(3, now_us);
  s.Bind(4, until_us);
  s.Bind(5, static_cast<std::int64_t>(free_if_holder_silent ? 1 : 0));
  const int code = s.Step();
  if (code != SQLITE_ROW && code != SQLITE_DONE) return SqliteError(db, code, "lease");
  return code == SQLITE_ROW;
}

absl::StatusOr<std::int64_t> LeaseHolderAliveUntil(sqlite3* db, const std::string& name) {
  Statement s(db,
              "SELECT coalesce(a.until_us, 0) FROM leases l LEFT JOIN alive a "
              "ON a.holder = l.holder WHERE l.name = ?1");
  OAIPP_RETURN_IF_ERROR(s.prepared("lease holder"));
  s.Bind(1, name);
  const int code = s.Step();
  if (code == SQLITE_DONE) return 0;  // nobody holds it
  if (code != SQLITE_ROW) return SqliteError(db, code, "lease holder");
  return s.Int(0);
}

absl::Status Heartbeat(sqlite3* db, const std::string& holder, std::int64_t until_us) {
  Statement s(db,
              "INSERT INTO alive(holder, until_us) VALUES(?1, ?2) "
              "ON CONFLICT(holder) DO UPDATE SET until_us = excluded.until_us");
  OAIPP_RETURN_IF_ERROR(s.prepared("heartbeat"));
  s.Bind(1, holder);
  s.Bind(2, until_us);
  return s.Done("heartbeat");
}

absl::Status Retire(sqlite3* db, const std::string& holder) {
  for (const char* sql :
       {"DELETE FROM alive WHERE holder = ?1", "DELETE FROM leases WHERE holder = ?1"}) {
    Statement s(db, sql);
    OAIPP_RETURN_IF_ERROR(s.prepared("retire"));
    s.Bind(1, holder);
    OAIPP_RETURN_IF_ERROR(s.Done("retire"));
  }
  return absl::OkStatus();
}

}  // namespace oaipp::server::sqlite
