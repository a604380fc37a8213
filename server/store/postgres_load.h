// Missions read back from the PostgreSQL store, inside a transaction the
// caller opened. Internal to server/store/.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <pqxx/pqxx>

#include "absl/status/statusor.h"
#include "server/store/mission_store.h"

namespace oaipp::server::postgres {

// Missions (all, or the one with id *only) with their snapshot and the
// records after it, in the order MissionStore::LoadAll promises, less what
// a reader holding the mission through record `have_through` has
// (KeepOnlyAfter: a snapshot it holds is not read at all). `tx`: a
// read-only repeatable-read transaction, or a claim's read-write one. The
// snapshots' states come in PostgreSQL's binary format (ExecBinary).
// Throws as libpqxx does; Unavailable when a snapshot changed between its
// two reads (it cannot within one transaction of either kind; checked all
// the same).
[[nodiscard]] absl::StatusOr<std::vector<StoredMission>> LoadMissions(
    pqxx::dbtransaction& tx, const std::string* only, std::int64_t have_through = 0);

}  // namespace oaipp::server::postgres
