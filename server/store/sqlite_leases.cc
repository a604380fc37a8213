#include "server/store/sqlite_leases.h"

#include <algorithm>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
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

absl::Status Heartbeat(sqlite3* db, const std::string& holder, std::int64_t until_us, int ring_id) {
  Statement s(db,
              "INSERT INTO alive(holder, until_us, ring_id) VALUES(?1, ?2, ?3) "
              "ON CONFLICT(holder) DO UPDATE SET until_us = excluded.until_us, "
              "ring_id = excluded.ring_id");
  OAIPP_RETURN_IF_ERROR(s.prepared("heartbeat"));
  s.Bind(1, holder);
  s.Bind(2, until_us);
  s.Bind(3, static_cast<std::int64_t>(ring_id));
  return s.Done("heartbeat");
}

absl::StatusOr<StoreView> View(sqlite3* db, const std::string& lease_prefix, std::int64_t now_us) {
  StoreView view;
  {
    Statement s(db, "SELECT holder, ring_id FROM alive WHERE until_us >= ?1 ORDER BY holder");
    OAIPP_RETURN_IF_ERROR(s.prepared("view"));
    s.Bind(1, now_us);
    int code = SQLITE_ROW;
    while ((code = s.Step()) == SQLITE_ROW) {
      view.alive.push_back({.holder = s.Bytes(0), .ring_id = static_cast<int>(s.Int(1))});
    }
    if (code != SQLITE_DONE) return SqliteError(db, code, "view");
  }
  // SQLite 3.40 has no unhex(): the lease names are decoded here.
  std::vector<StoreView::Held> leased;
  {
    Statement s(db,
                "SELECT l.name, l.holder, coalesce(a.until_us >= ?2, 0), coalesce(a.ring_id, 0) "
                "FROM leases l LEFT JOIN alive a ON a.holder = l.holder "
                "WHERE substr(l.name, 1, length(?1)) = ?1 ORDER BY l.name");
    OAIPP_RETURN_IF_ERROR(s.prepared("view"));
    s.Bind(1, lease_prefix);
    s.Bind(2, now_us);
    int code = SQLITE_ROW;
    while ((code = s.Step()) == SQLITE_ROW) {
      const std::string name = s.Bytes(0);
      const absl::string_view hex = absl::string_view(name).substr(lease_prefix.size());
      if (hex.size() % 2 != 0 || !std::all_of(hex.begin(), hex.end(), absl::ascii_isxdigit)) {
        continue;  // not a mission's lease
      }
      leased.push_back({.mission_id = absl::HexStringToBytes(hex),
                        .holder = s.Bytes(1),
                        .holder_alive = s.Int(2) != 0,
                        .holder_ring_id = static_cast<int>(s.Int(3))});
    }
    if (code != SQLITE_DONE) return SqliteError(db, code, "view");
  }
  for (StoreView::Held& held : leased) {
    Statement s(db,
                "SELECT coalesce((SELECT max(sequence) FROM records WHERE mission_id = ?1), "
                "(SELECT sequence FROM snapshots WHERE mission_id = ?1), 0) "
                "FROM missions WHERE id = ?1");
    OAIPP_RETURN_IF_ERROR(s.prepared("view"));
    s.Bind(1, held.mission_id);
    const int code = s.Step();
    if (code == SQLITE_DONE) continue;  // deleted, its lease not yet
    if (code != SQLITE_ROW) return SqliteError(db, code, "view");
    held.last_sequence = s.Int(0);
    view.held.push_back(std::move(held));
  }
  return view;
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
