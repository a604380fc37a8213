// The SQLite store's leases and heartbeats (MissionStore::TryLease,
// LeaseHolderAliveUntil, Heartbeat, Retire, View) on its connection: the rows servers sharing a
// store agree with on who sweeps it and who serves each mission. Internal to server/store/; the
// caller holds the connection's lock.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/store/mission_store.h"

namespace oaipp::server::sqlite {

[[nodiscard]] absl::StatusOr<bool> TryLease(sqlite3* db, const std::string& name,
                                            const std::string& holder, std::int64_t now_us,
                                            std::int64_t until_us, bool free_if_holder_silent);
[[nodiscard]] absl::StatusOr<std::int64_t> LeaseHolderAliveUntil(sqlite3* db,
                                                                 const std::string& name);
[[nodiscard]] absl::Status Heartbeat(sqlite3* db, const std::string& holder, std::int64_t until_us,
                                     int ring_id);
[[nodiscard]] absl::StatusOr<StoreView> View(sqlite3* db, const std::string& lease_prefix,
                                             std::int64_t now_us);
[[nodiscard]] absl::Status Retire(sqlite3* db, const std::string& holder);

}  // namespace oaipp::server::sqlite
