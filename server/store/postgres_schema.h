// The PostgreSQL store's schema version and its set-up
// (postgres_schema.cc; docs/storage.md). Internal to server/store/.
#pragma once

#include <cstdint>

#include <pqxx/pqxx>

#include "absl/status/status.h"

namespace oaipp::server::postgres {

// The schema version this code reads and writes (store_info 'schema_version').
// 1: missions, records, snapshots, deletions, mission_numbers.
// 2: + missions.epoch (ownership, for servers sharing the store), an index
//    of missions by request_id.
// Later tables and indexes (the listing's index, secrets, leases, the
// servers alive and their ring ids) come with the schema's idempotent DDL,
// which runs at every open.
inline constexpr std::int64_t kSchemaVersion = 2;

// Held while the schema is created: CREATE ... IF NOT EXISTS is not atomic
// against a concurrent create of the same name, so two servers opening a
// new database at once take turns. Any constant works; this one is ours.
inline constexpr std::int64_t kSchemaLockKey = 0x6f61697070;  // "oaipp"

// In `tx`, which the caller commits: checks that the database keeps commits
// durable, takes kSchemaLockKey, refuses a schema newer than kSchemaVersion
// unchanged, and brings an older one (or an empty database) up to it.
// FailedPrecondition names what is wrong; throws as libpqxx does
// (pqxx::deadlock_detected when the database rolled `tx` back to break a
// deadlock with another server's transactions).
[[nodiscard]] absl::Status BringSchemaUpToDate(pqxx::work& tx);

}  // namespace oaipp::server::postgres
