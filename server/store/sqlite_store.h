// The embedded mission store: one SQLite file (WAL journal,
// synchronous=FULL, so a record is on disk when Append returns).
//
//   OAIPP_ASSIGN_OR_RETURN(std::unique_ptr<MissionStore> store,
//                          OpenSqliteStore("/var/lib/oaipp/missions.db"));
#pragma once

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "server/store/mission_store.h"

namespace oaipp::server {

// Opens (creating if needed) the store in the file at `path`; its folder
// must exist. Unavailable when the file cannot be opened or its schema
// cannot be created.
[[nodiscard]] absl::StatusOr<std::unique_ptr<MissionStore>> OpenSqliteStore(
    const std::string& path);

}  // namespace oaipp::server
