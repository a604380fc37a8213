#include "server/store/postgres_schema.h"

#include <cstdint>
#include <string>

#include "absl/strings/str_cat.h"

namespace oaipp::server::postgres {
namespace {

// Every stored string is bytea, ids and request_ids too: the store keeps
// bytes, and text would refuse a NUL or a byte sequence that is not valid in
// the database's encoding. bytea also compares byte by byte, so missions
// created in the same microsecond come back in the same order as from the
// SQLite store, whatever the database's collation.
constexpr const char* kSchema = R"sql(
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

}  // namespace

absl::Status BringSchemaUpToDate(pqxx::work& tx) {
  // A commit acknowledged before it is on disk would break the contract's
  // "durably"; such a server is a configuration error, found here rather
  // than after a crash.
  const pqxx::row settings =
      tx.exec1("SELECT current_setting('fsync'), current_setting('synchronous_commit')");
  if (settings[0].as<std::string>() != "on" || settings[1].as<std::string>() == "off") {
    return absl::FailedPreconditionError(
        absl::StrCat("store: open: the database does not keep commits durable (fsync=",
                     settings[0].as<std::string>(),
                     ", synchronous_commit=", settings[1].as<std::string>(), ")"));
  }
  tx.exec_params("SELECT pg_advisory_xact_lock($1)", kSchemaLockKey);
  // The version is read before the schema is touched: a newer server's
  // database is refused unchanged. Everything in kSchema is idempotent, so
  // an older database is brought up to this version by running it.
  tx.exec0("CREATE TABLE IF NOT EXISTS store_info(key text PRIMARY KEY, value bigint NOT NULL)");
  tx.exec_params0(
      "INSERT INTO store_info(key, value) VALUES('schema_version', $1) "
      "ON CONFLICT (key) DO NOTHING",
      kSchemaVersion);
  const auto version =
      tx.exec1("SELECT value FROM store_info WHERE key = 'schema_version'")[0].as<std::int64_t>();
  if (version > kSchemaVersion) {
    return absl::FailedPreconditionError(absl::StrCat("store: open: schema version ", version,
                                                      " is newer than this server's (",
                                                      kSchemaVersion, ")"));
  }
  tx.exec0(kSchema);
  tx.exec_params0("UPDATE store_info SET value = $1 WHERE key = 'schema_version'", kSchemaVersion);
  return absl::OkStatus();
}

}  // namespace oaipp::server::postgres
