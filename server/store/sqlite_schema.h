// The SQLite store's tables (docs/storage.md), and the steps that bring an
// older file up to them. Internal to server/store/.
#pragma once

#include <sqlite3.h>

#include "absl/status/status.h"

namespace oaipp::server::sqlite {

// The schema version this code reads and writes (PRAGMA user_version).
// 1: missions, records, deletions, counters. 2: + snapshots, write times.
// 3: + missions.epoch (ownership; always kFirstEpoch for a single server).
// Later tables and indexes come with kSchema, which runs at every open.
inline constexpr int kSchemaVersion = 3;

inline constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS counters(
  name TEXT PRIMARY KEY,
  value INTEGER NOT NULL);
CREATE TABLE IF NOT EXISTS missions(
  id TEXT PRIMARY KEY,
  spec BLOB NOT NULL,
  request_id TEXT NOT NULL,
  fingerprint TEXT NOT NULL,
  create_time_us INTEGER NOT NULL,
  epoch INTEGER NOT NULL DEFAULT 1);
CREATE TABLE IF NOT EXISTS records(
  mission_id TEXT NOT NULL REFERENCES missions(id) ON DELETE CASCADE,
  sequence INTEGER NOT NULL,
  kind INTEGER NOT NULL,
  payload BLOB NOT NULL,
  request_id TEXT NOT NULL,
  fingerprint TEXT NOT NULL,
  result BLOB NOT NULL,
  planner_state BLOB NOT NULL,
  write_time_us INTEGER NOT NULL DEFAULT 0,
  PRIMARY KEY(mission_id, sequence));
CREATE TABLE IF NOT EXISTS snapshots(
  mission_id TEXT PRIMARY KEY REFERENCES missions(id) ON DELETE CASCADE,
  sequence INTEGER NOT NULL,
  state BLOB NOT NULL,
  write_time_us INTEGER NOT NULL);
CREATE TABLE IF NOT EXISTS deletions(
  request_id TEXT PRIMARY KEY,
  mission_id TEXT NOT NULL,
  time_us INTEGER NOT NULL DEFAULT 0);
CREATE TABLE IF NOT EXISTS secrets(
  name TEXT PRIMARY KEY,
  value BLOB NOT NULL);
CREATE TABLE IF NOT EXISTS leases(
  name TEXT PRIMARY KEY,
  holder TEXT NOT NULL,
  until_us INTEGER NOT NULL);
CREATE TABLE IF NOT EXISTS alive(
  holder TEXT PRIMARY KEY,
  until_us INTEGER NOT NULL,
  ring_id INTEGER NOT NULL DEFAULT 0);
CREATE INDEX IF NOT EXISTS missions_by_creation ON missions(create_time_us, id);
)sql";

// From version 1 (written before snapshots): the new columns; the new table
// comes from kSchema.
inline constexpr const char* kFromVersion1 = R"sql(
ALTER TABLE records ADD COLUMN write_time_us INTEGER NOT NULL DEFAULT 0;
ALTER TABLE deletions ADD COLUMN time_us INTEGER NOT NULL DEFAULT 0;
)sql";

// From version 2 (written before epochs).
inline constexpr const char* kFromVersion2 = R"sql(
ALTER TABLE missions ADD COLUMN epoch INTEGER NOT NULL DEFAULT 1;
)sql";

// Sets the connection up (WAL, full sync, foreign keys) and creates the
// tables or brings an older file up to kSchemaVersion; FailedPrecondition
// for a file a newer server wrote (sqlite_schema.cc).
[[nodiscard]] absl::Status OpenSchema(sqlite3* db);

}  // namespace oaipp::server::sqlite
