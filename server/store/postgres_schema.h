// The PostgreSQL store's tables (docs/storage.md). Internal to
// server/store/.
#pragma once

#include <cstdint>

namespace oaipp::server::postgres {

// The schema version this code reads and writes (store_info 'schema_version').
// 1: missions, records, snapshots, deletions, mission_numbers.
// 2: + missions.epoch (ownership, for servers sharing the store), an index
//    of missions by request_id.
// Later tables and indexes (the listing's index, secrets, leases, the
// servers alive and their ring ids) come with
// kSchema, which is idempotent and runs at every open.
inline constexpr std::int64_t kSchemaVersion = 2;

// Every stored string is bytea, ids and request_ids too: the store keeps
// bytes, and text would refuse a NUL or a byte sequence that is not valid in
// the database's encoding. bytea also compares byte by byte, so missions
// created in the same microsecond come back in the same order as from the
// SQLite store, whatever the database's collation.
inline constexpr const char* kSchema = R"sql(
CREATE SEQUENCE IF NOT EXISTS mission_numbers;
CREATE TABLE IF NOT EXISTS store_info(
  key text PRIMARY KEY,
  value bigint NOT NULL);
CREATE TABLE IF NOT EXISTS missions(
  id bytea PRIMARY KEY,
  spec bytea NOT NULL,
  request_id bytea NOT NULL,
  fingerprint bytea NOT NULL,
  create_time_us bigint NOT NULL);
CREATE TABLE IF NOT EXISTS records(
  mission_id bytea NOT NULL REFERENCES missions(id) ON DELETE CASCADE,
  sequence bigint NOT NULL,
  kind integer NOT NULL,
  payload bytea NOT NULL,
  request_id bytea NOT NULL,
  fingerprint bytea NOT NULL,
  result bytea NOT NULL,
  planner_state bytea NOT NULL,
  write_time_us bigint NOT NULL,
  PRIMARY KEY(mission_id, sequence));
CREATE TABLE IF NOT EXISTS snapshots(
  mission_id bytea PRIMARY KEY REFERENCES missions(id) ON DELETE CASCADE,
  sequence bigint NOT NULL,
  state bytea NOT NULL,
  write_time_us bigint NOT NULL);
CREATE TABLE IF NOT EXISTS deletions(
  request_id bytea PRIMARY KEY,
  mission_id bytea NOT NULL,
  time_us bigint NOT NULL);
CREATE INDEX IF NOT EXISTS deletions_by_time ON deletions(time_us);
ALTER TABLE missions ADD COLUMN IF NOT EXISTS epoch bigint NOT NULL DEFAULT 1;
CREATE INDEX IF NOT EXISTS missions_by_request ON missions(request_id);
CREATE INDEX IF NOT EXISTS missions_by_creation ON missions(create_time_us, id);
CREATE TABLE IF NOT EXISTS store_secrets(
  name text PRIMARY KEY,
  value bytea NOT NULL);
CREATE TABLE IF NOT EXISTS store_leases(
  name text PRIMARY KEY,
  holder bytea NOT NULL,
  until_us bigint NOT NULL);
CREATE INDEX IF NOT EXISTS store_leases_by_holder ON store_leases(holder);
CREATE TABLE IF NOT EXISTS store_alive(
  holder bytea PRIMARY KEY,
  until_us bigint NOT NULL);
ALTER TABLE store_alive ADD COLUMN IF NOT EXISTS ring_id integer NOT NULL DEFAULT 0;
)sql";

// Held while the schema is created: CREATE ... IF NOT EXISTS is not atomic
// against a concurrent create of the same name, so two servers opening a
// new database at once take turns. Any constant works; this one is ours.
inline constexpr std::int64_t kSchemaLockKey = 0x6f61697070;  // "oaipp"

}  // namespace oaipp::server::postgres
