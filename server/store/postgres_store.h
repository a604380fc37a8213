// The networked mission store: PostgreSQL (15), through libpqxx. Several
// oaipp-server processes can share it, and writes of different missions go
// over different connections of a small pool instead of queueing behind one
// lock. A record is durable when Append returns (the server's
// synchronous_commit=on, its default; the store refuses to open when it or
// fsync is off).
//
//   OAIPP_ASSIGN_OR_RETURN(
//       std::unique_ptr<MissionStore> store,
//       OpenPostgresStore("postgresql://oaipp@db.example:5432/oaipp", /*connections=*/8));
//   OAIPP_RETURN_IF_ERROR(store->Append("m-000001", record));
#pragma once

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "server/store/mission_store.h"

namespace oaipp::server {

// Opens the store in the database named by `uri`, a libpq connection string
// ("postgresql://user@host:port/db", "...?host=/run/dir" for a unix socket,
// or "host=... dbname=..."), and creates its tables and sequence when they
// are missing. At most `connections` (>= 1) connections are open at once; a
// call waits for a free one. A connection that breaks is dropped and opened
// again by a later call, so the store survives a restart of the server
// without being reopened (the calls in between fail with Unavailable).
// InvalidArgument for connections < 1; Unavailable when the database cannot
// be reached or its schema cannot be created; FailedPrecondition when the
// database would not keep commits durable or holds a newer schema.
[[nodiscard]] absl::StatusOr<std::unique_ptr<MissionStore>> OpenPostgresStore(
    const std::string& uri, int connections = 4);

}  // namespace oaipp::server
