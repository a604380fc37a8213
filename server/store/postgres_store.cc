#include "server/store/postgres_store.h"

#include <poll.h>

#include <cstdint>
#include <exception>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <openssl/rand.h>
#include <pqxx/pqxx>

#include "absl/base/thread_annotations.h"
#include "absl/strings/ascii.h"
#include "absl/strings/cord.h"
#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "absl/strings/strip.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "core/common/status_macros.h"
#include "server/store/postgres_connection.h"
#include "server/store/postgres_load.h"
#include "server/store/postgres_schema.h"

namespace oaipp::server {
namespace {

using postgres::Blob;
using postgres::Connection;
using postgres::ConnectionPool;
using postgres::CurrentError;
using postgres::FirstLine;
using postgres::InDoubt;
using postgres::LoadMissions;
using postgres::NoMission;
using postgres::Printable;
using postgres::ReadBytes;
using postgres::WithConnectTimeout;

std::int64_t NowUs() { return absl::ToUnixMicros(absl::Now()); }

class PostgresStore final : public MissionStore {
 public:
  PostgresStore(std::string uri, int connections) : uri_(std::move(uri)), pool_(connections) {}

  // Checks that commits are durable, then brings the schema up to this
  // version. Its idempotent DDL takes table locks that the transactions of
  // servers already running on the store may hold in another order, so the
  // database can pick this transaction as a deadlock's victim: it is rolled
  // back whole and tried again.
  absl::Status Init() {
    constexpr int kAttempts = 5;
    absl::Status status = InitOnce();
    for (int attempt = 1; attempt < kAttempts && status.code() == absl::StatusCode::kAborted;
         ++attempt) {
      absl::SleepFor(absl::Milliseconds(50 * attempt));
      status = InitOnce();
    }
    if (status.code() != absl::StatusCode::kAborted) return status;
    return absl::UnavailableError(absl::StrCat(status.message(), " (", kAttempts, " attempts)"));
  }

  absl::StatusOr<std::int64_t> NextMissionNumber() override {
    return Call("next mission number",
                [&](pqxx::connection& conn, CallState& state) -> absl::StatusOr<std::int64_t> {
                  pqxx::work tx(conn);
                  const auto number =
                      tx.exec1("SELECT nextval('mission_numbers')")[0].as<std::int64_t>();
                  // nextval logs only every 32nd value, and a transaction
                  // that wrote nothing else commits without waiting for the
                  // disk: if the call that logged ahead never committed, the
                  // number could come back after a crash. Writing it makes
                  // this commit flush the log up to and past that value.
                  tx.exec_params0(
                      "INSERT INTO store_info(key, value) VALUES('mission_number', $1) "
                      "ON CONFLICT (key) DO UPDATE SET "
                      "value = GREATEST(store_info.value, EXCLUDED.value)",
                      number);
                  Commit(tx, state);
                  return number;
                });
  }

  absl::Status CreateMission(const StoredMission& m) override {
    return Call(absl::StrCat("create mission '", Printable(m.id), "'"),
                [&](pqxx::connection& conn, CallState& state) -> absl::Status {
                  pqxx::work tx(conn);
                  // A taken id is a unique violation: AlreadyExists.
                  tx.exec_params0(
                      "INSERT INTO missions(id, spec, request_id, fingerprint, create_time_us) "
                      "VALUES($1, $2, $3, $4, $5)",
                      Blob(m.id), Blob(m.spec), Blob(m.request_id), Blob(m.fingerprint),
                      m.create_time_unix_us);
                  Commit(tx, state);
                  return absl::OkStatus();
                });
  }

  absl::Status Append(const std::string& mission_id, const LogRecord& r) override {
    const std::string what =
        absl::StrCat("append to '", Printable(mission_id), "' at ", r.sequence);
    if (r.sequence < 1) {
      return absl::InvalidArgumentError(absl::StrCat("store: ", what, ": sequences start at 1"));
    }
    const std::int64_t write_time_us = r.write_time_unix_us != 0 ? r.write_time_unix_us : NowUs();
    return Call(what, [&](pqxx::connection& conn, CallState& state) -> absl::Status {
      pqxx::work tx(conn);
      // The share lock keeps PutSnapshot (which takes the mission row for
      // update) from dropping records between this check and the insert,
      // and DeleteMission from removing the mission under it; appends to
      // the same mission share it.
      // It also orders this append against a Claim (which updates the row):
      // an append that waited for a claim sees the new epoch and is refused.
      const pqxx::result mission = tx.exec_params(
          "SELECT s.sequence, m.epoch FROM missions m LEFT JOIN snapshots s ON s.mission_id = m.id "
          "WHERE m.id = $1 FOR SHARE OF m",
          Blob(mission_id));
      if (mission.empty()) return NoMission(what);
      if (const auto epoch = mission[0][1].as<std::int64_t>(); epoch != r.epoch) {
        return FencedError(what, epoch, r.epoch);
      }
      // A snapshot dropped the records it covers, so a retry of one of them
      // cannot be told from a reuse any more; the writer that sent it is
      // behind the snapshot either way.
      if (!mission[0][0].is_null() && r.sequence <= mission[0][0].as<std::int64_t>()) {
        return absl::AlreadyExistsError(absl::StrCat(
            "store: ", what, ": covered by the snapshot at ", mission[0][0].as<std::int64_t>()));
      }
      const pqxx::result inserted = tx.exec_params(
          "INSERT INTO records(mission_id, sequence, kind, payload, request_id, fingerprint, "
          "result, planner_state, write_time_us) VALUES($1, $2, $3, $4, $5, $6, $7, $8, $9) "
          "ON CONFLICT (mission_id, sequence) DO NOTHING",
          Blob(mission_id), r.sequence, static_cast<int>(r.kind), Blob(r.payload),
          Blob(r.request_id), Blob(r.fingerprint), Blob(r.result), Blob(r.planner_state),
          write_time_us);
      if (inserted.affected_rows() == 1) {
        Commit(tx, state);
        return absl::OkStatus();
      }
      // The same request at the same place: a retry of a write whose outcome
      // the writer could not know. Anything else is a second writer.
      const pqxx::row stored = tx.exec_params1(
          "SELECT payload, request_id, fingerprint FROM records "
          "WHERE mission_id = $1 AND sequence = $2",
          Blob(mission_id), r.sequence);
      if (ReadBytes(stored[0]) == r.payload && ReadBytes(stored[1]) == r.request_id &&
          ReadBytes(stored[2]) == r.fingerprint) {
        return absl::OkStatus();
      }
      return absl::AlreadyExistsError(
          absl::StrCat("store: ", what, ": the sequence holds another request"));
    });
  }

  absl::Status PutSnapshot(const std::string& mission_id, const StoredSnapshot& snap) override {
    const std::string what =
        absl::StrCat("snapshot of '", Printable(mission_id), "' at ", snap.sequence);
    if (snap.sequence < 1) {
      return absl::InvalidArgumentError(absl::StrCat("store: ", what, ": sequences start at 1"));
    }
    const std::int64_t write_time_us =
        snap.write_time_unix_us != 0 ? snap.write_time_unix_us : NowUs();
    return Call(what, [&](pqxx::connection& conn, CallState& state) -> absl::Status {
      pqxx::work tx(conn);
      // NO KEY UPDATE waits for appends in flight (FOR SHARE) but not for
      // the key-share locks of foreign-key checks.
      const pqxx::result mission = tx.exec_params(
          "SELECT s.sequence, m.epoch FROM missions m LEFT JOIN snapshots s ON s.mission_id = m.id "
          "WHERE m.id = $1 FOR NO KEY UPDATE OF m",
          Blob(mission_id));
      if (mission.empty()) return NoMission(what);
      if (const auto epoch = mission[0][1].as<std::int64_t>(); epoch != snap.epoch) {
        return FencedError(what, epoch, snap.epoch);
      }
      if (!mission[0][0].is_null() && snap.sequence <= mission[0][0].as<std::int64_t>()) {
        return absl::OkStatus();  // not later than the stored one: ignored
      }
      tx.exec_params0(
          "INSERT INTO snapshots(mission_id, sequence, state, write_time_us) "
          "VALUES($1, $2, $3, $4) ON CONFLICT (mission_id) DO UPDATE SET "
          "sequence = EXCLUDED.sequence, state = EXCLUDED.state, "
          "write_time_us = EXCLUDED.write_time_us",
          Blob(mission_id), snap.sequence, Blob(snap.state), write_time_us);
      tx.exec_params0("DELETE FROM records WHERE mission_id = $1 AND sequence <= $2",
                      Blob(mission_id), snap.sequence);
      Commit(tx, state);
      return absl::OkStatus();
    });
  }

  absl::Status DeleteMission(const std::string& mission_id, const std::string& request_id,
                             std::int64_t epoch) override {
    const std::string what = absl::StrCat("delete mission '", Printable(mission_id), "'");
    return Call(what, [&](pqxx::connection& conn, CallState& state) -> absl::Status {
      pqxx::work tx(conn);
      const pqxx::result held =
          tx.exec_params("SELECT epoch FROM missions WHERE id = $1 FOR UPDATE", Blob(mission_id));
      if (held.empty()) return NoMission(what);
      if (const auto stored = held[0][0].as<std::int64_t>(); stored != epoch) {
        return FencedError(what, stored, epoch);
      }
      // Records and snapshot go with it (ON DELETE CASCADE), in this
      // transaction.
      tx.exec_params0("DELETE FROM missions WHERE id = $1", Blob(mission_id));
      if (!request_id.empty()) {
        // A request_id that already deleted a mission keeps its first answer.
        tx.exec_params0(
            "INSERT INTO deletions(request_id, mission_id, time_us) VALUES($1, $2, $3) "
            "ON CONFLICT (request_id) DO NOTHING",
            Blob(request_id), Blob(mission_id), NowUs());
      }
      Commit(tx, state);
      return absl::OkStatus();
    });
  }

  absl::StatusOr<std::vector<StoredMission>> LoadAll() override {
    return Call(
        "load all missions",
        [&](pqxx::connection& conn, CallState&) -> absl::StatusOr<std::vector<StoredMission>> {
          ReadOnly tx(conn);
          return LoadMissions(tx, nullptr);
        });
  }

  absl::StatusOr<StoredMission> Load(const std::string& mission_id) override {
    return LoadAfter(mission_id, 0);
  }

  absl::StatusOr<StoredMission> LoadAfter(const std::string& mission_id,
                                          std::int64_t have_through) override {
    const std::string what = absl::StrCat("load mission '", Printable(mission_id), "'");
    return Call(what, [&](pqxx::connection& conn, CallState&) -> absl::StatusOr<StoredMission> {
      ReadOnly tx(conn);
      OAIPP_ASSIGN_OR_RETURN(std::vector<StoredMission> found,
                             LoadMissions(tx, &mission_id, have_through));
      if (found.empty()) return NoMission(what);
      return std::move(found.front());
    });
  }

  absl::StatusOr<StoredMission> Claim(const std::string& mission_id,
                                      std::int64_t have_through) override {
    const std::string what = absl::StrCat("claim mission '", Printable(mission_id), "'");
    return Call(
        what, [&](pqxx::connection& conn, CallState& state) -> absl::StatusOr<StoredMission> {
          // Read committed: the update waits for appends holding the row
          // (FOR SHARE) and takes it; the reads after it see those appends, and
          // appends that come later see the new epoch.
          pqxx::work tx(conn);
          const pqxx::result claimed =
              tx.exec_params("UPDATE missions SET epoch = epoch + 1 WHERE id = $1 RETURNING epoch",
                             Blob(mission_id));
          if (claimed.empty()) return NoMission(what);
          OAIPP_ASSIGN_OR_RETURN(std::vector<StoredMission> found,
                                 LoadMissions(tx, &mission_id, have_through));
          if (found.empty()) return NoMission(what);
          Commit(tx, state);
          return std::move(found.front());
        });
  }

  absl::StatusOr<std::int64_t> Epoch(const std::string& mission_id) override {
    const std::string what = absl::StrCat("epoch of '", Printable(mission_id), "'");
    return Call(what, [&](pqxx::connection& conn, CallState&) -> absl::StatusOr<std::int64_t> {
      pqxx::nontransaction tx(conn);
      const pqxx::result found =
          tx.exec_params("SELECT epoch FROM missions WHERE id = $1", Blob(mission_id));
      if (found.empty()) return NoMission(what);
      return found[0][0].as<std::int64_t>();
    });
  }

  absl::StatusOr<StoredMission> CreatedBy(const std::string& request_id) override {
    return Call("created by",
                [&](pqxx::connection& conn, CallState&) -> absl::StatusOr<StoredMission> {
                  pqxx::nontransaction tx(conn);
                  const pqxx::result found = tx.exec_params(
                      "SELECT id, request_id, fingerprint, create_time_us, epoch FROM missions "
                      "WHERE request_id = $1 ORDER BY create_time_us, id LIMIT 1",
                      Blob(request_id));
                  if (found.empty()) {
                    return absl::NotFoundError("store: no mission created by that request_id");
                  }
                  return StoredMission{.id = ReadBytes(found[0][0]),
                                       .request_id = ReadBytes(found[0][1]),
                                       .fingerprint = ReadBytes(found[0][2]),
                                       .create_time_unix_us = found[0][3].as<std::int64_t>(),
                                       .epoch = found[0][4].as<std::int64_t>()};
                });
  }

  absl::StatusOr<std::string> DeletedBy(const std::string& request_id) override {
    return Call("deleted by",
                [&](pqxx::connection& conn, CallState&) -> absl::StatusOr<std::string> {
                  pqxx::nontransaction tx(conn);
                  const pqxx::result found = tx.exec_params(
                      "SELECT mission_id FROM deletions WHERE request_id = $1", Blob(request_id));
                  if (found.empty()) {
                    return absl::NotFoundError("store: no deletion by that request_id");
                  }
                  return ReadBytes(found[0][0]);
                });
  }

  absl::Status ForgetDeletionsBefore(std::int64_t unix_us) override {
    return Call("forget deletions", [&](pqxx::connection& conn, CallState& state) -> absl::Status {
      pqxx::work tx(conn);
      tx.exec_params0("DELETE FROM deletions WHERE time_us < $1", unix_us);
      tx.exec_params0("DELETE FROM store_leases WHERE until_us < $1", unix_us);
      tx.exec_params0("DELETE FROM store_alive WHERE until_us < $1", unix_us);
      Commit(tx, state);
      return absl::OkStatus();
    });
  }

  absl::StatusOr<std::vector<MissionListing>> List(const std::string& prefix,
                                                   std::int64_t after_time_us,
                                                   const std::string& after_id,
                                                   int limit) override {
    return Call(
        "list",
        [&](pqxx::connection& conn, CallState&) -> absl::StatusOr<std::vector<MissionListing>> {
          ReadOnly tx(conn);
          const pqxx::result rows = tx.exec_params(
              "SELECT id, spec, create_time_us FROM missions "
              "WHERE substring(id from 1 for length($1::bytea)) = $1::bytea "
              "AND position('\\x2f'::bytea in substring(id from length($1::bytea) + 1)) = 0 "
              "AND (create_time_us > $2 OR (create_time_us = $2 AND id > $3::bytea)) "
              "ORDER BY create_time_us, id LIMIT $4",
              Blob(prefix), after_time_us, Blob(after_id), limit);
          std::vector<MissionListing> out;
          for (const pqxx::row& row : rows) {
            out.push_back({.id = ReadBytes(row[0]),
                           .spec = ReadBytes(row[1]),
                           .create_time_unix_us = row[2].as<std::int64_t>()});
          }
          return out;
        });
  }

  absl::StatusOr<bool> TryLease(const std::string& name, const std::string& holder,
                                std::int64_t now_us, std::int64_t until_us,
                                bool free_if_holder_silent) override {
    return Call("lease", [&](pqxx::connection& conn, CallState& state) -> absl::StatusOr<bool> {
      // The row is taken or renewed only when free: two servers asking at
      // once are ordered by the row's lock, and the second sees the first's.
      pqxx::work tx(conn);
      const pqxx::result held = tx.exec_params(
          "INSERT INTO store_leases(name, holder, until_us) VALUES($1, $2, $4) "
          "ON CONFLICT (name) DO UPDATE SET holder = EXCLUDED.holder, "
          "until_us = EXCLUDED.until_us "
          "WHERE store_leases.until_us < $3 OR store_leases.holder = EXCLUDED.holder "
          "OR ($5 AND NOT EXISTS (SELECT 1 FROM store_alive a "
          "WHERE a.holder = store_leases.holder AND a.until_us >= $3)) "
          "RETURNING holder",
          name, Blob(holder), now_us, until_us, free_if_holder_silent);
      Commit(tx, state);
      return !held.empty();
    });
  }

  absl::StatusOr<std::int64_t> LeaseHolderAliveUntil(const std::string& name) override {
    return Call("lease holder",
                [&](pqxx::connection& conn, CallState&) -> absl::StatusOr<std::int64_t> {
                  pqxx::nontransaction tx(conn);
                  const pqxx::result found = tx.exec_params(
                      "SELECT coalesce(a.until_us, 0) FROM store_leases l LEFT JOIN store_alive a "
                      "ON a.holder = l.holder WHERE l.name = $1",
                      name);
                  return found.empty() ? 0 : found[0][0].as<std::int64_t>();
                });
  }

  absl::Status Heartbeat(const std::string& holder, std::int64_t until_us, int ring_id) override {
    return CallOn(heartbeat_pool_, "heartbeat",
                  [&](pqxx::connection& conn, CallState& state) -> absl::Status {
                    pqxx::work tx(conn);
                    // Not waiting for the disk: a heartbeat that a crash of
                    // the store loses only makes its server look silent
                    // sooner, and a mission taken over then is fenced by the
                    // claim's epoch, which is committed durably (Claim). A
                    // slow fsync, by contrast, could make a live server look
                    // silent to the others.
                    tx.exec("SET LOCAL synchronous_commit TO OFF");
                    tx.exec_params(
                        "INSERT INTO store_alive(holder, until_us, ring_id) VALUES($1, $2, $3) "
                        "ON CONFLICT (holder) DO UPDATE SET until_us = EXCLUDED.until_us, "
                        "ring_id = EXCLUDED.ring_id",
                        Blob(holder), until_us, ring_id);
                    Commit(tx, state);
                    return absl::OkStatus();
                  });
  }

  absl::StatusOr<StoreView> View(const std::string& lease_prefix, std::int64_t now_us) override {
    return Call("view", [&](pqxx::connection& conn, CallState&) -> absl::StatusOr<StoreView> {
      ReadOnly tx(conn);
      StoreView view;
      for (const pqxx::row& row :
           tx.exec_params("SELECT holder, ring_id FROM store_alive WHERE until_us >= $1 "
                          "ORDER BY holder",
                          now_us)) {
        view.alive.push_back({.holder = ReadBytes(row[0]), .ring_id = row[1].as<int>()});
      }
      // A mission's last sequence: its last record's, or without records
      // after its snapshot the snapshot's (both by primary key).
      for (const pqxx::row& row : tx.exec_params(
               "SELECT m.id, l.holder, coalesce(a.until_us >= $2, false), "
               "coalesce(a.ring_id, 0), coalesce((SELECT max(r.sequence) FROM records r "
               "WHERE r.mission_id = m.id), (SELECT s.sequence FROM snapshots s "
               "WHERE s.mission_id = m.id), 0) "
               "FROM store_leases l LEFT JOIN store_alive a ON a.holder = l.holder "
               "JOIN missions m ON m.id = CASE WHEN substr(l.name, length($1) + 1) "
               "~ '^([0-9a-f][0-9a-f])*$' THEN decode(substr(l.name, length($1) + 1), 'hex') END "
               "WHERE starts_with(l.name, $1) ORDER BY m.id",
               lease_prefix, now_us)) {
        view.held.push_back({.mission_id = ReadBytes(row[0]),
                             .holder = ReadBytes(row[1]),
                             .holder_alive = row[2].as<bool>(),
                             .holder_ring_id = row[3].as<int>(),
                             .last_sequence = row[4].as<std::int64_t>()});
      }
      return view;
    });
  }

  absl::Status Retire(const std::string& holder) override {
    return Call("retire", [&](pqxx::connection& conn, CallState& state) -> absl::Status {
      pqxx::work tx(conn);
      tx.exec_params("DELETE FROM store_alive WHERE holder = $1", Blob(holder));
      tx.exec_params("DELETE FROM store_leases WHERE holder = $1", Blob(holder));
      Commit(tx, state);
      return absl::OkStatus();
    });
  }

  absl::StatusOr<std::vector<std::pair<std::string, std::int64_t>>> IdleSince(
      std::int64_t before_us, int limit) override {
    return Call(
        "idle missions",
        [&](pqxx::connection& conn,
            CallState&) -> absl::StatusOr<std::vector<std::pair<std::string, std::int64_t>>> {
          ReadOnly tx(conn);
          const pqxx::result rows = tx.exec_params(
              "SELECT m.id, m.epoch FROM missions m WHERE m.create_time_us < $1 "
              "AND NOT EXISTS (SELECT 1 FROM records r WHERE r.mission_id = m.id "
              "AND r.write_time_us >= $1) "
              "AND NOT EXISTS (SELECT 1 FROM snapshots s WHERE s.mission_id = m.id "
              "AND s.write_time_us >= $1) "
              "ORDER BY m.create_time_us, m.id LIMIT $2",
              before_us, limit);
          std::vector<std::pair<std::string, std::int64_t>> out;
          for (const pqxx::row& row : rows) {
            out.emplace_back(ReadBytes(row[0]), row[1].as<std::int64_t>());
          }
          return out;
        });
  }

  absl::StatusOr<std::string> SigningKey() override {
    return Call("signing key",
                [&](pqxx::connection& conn, CallState& state) -> absl::StatusOr<std::string> {
                  std::string key(32, '\0');
                  if (RAND_bytes(reinterpret_cast<unsigned char*>(key.data()), 32) != 1) {
                    return absl::InternalError("signing key: no random bytes");
                  }
                  // The first server's key stays: a later insert does nothing
                  // (it waits for a concurrent first one) and reads that one.
                  pqxx::work tx(conn);
                  tx.exec_params0(
                      "INSERT INTO store_secrets(name, value) VALUES('page_tokens', $1) "
                      "ON CONFLICT (name) DO NOTHING",
                      Blob(key));
                  const pqxx::row stored =
                      tx.exec1("SELECT value FROM store_secrets WHERE name = 'page_tokens'");
                  std::string kept = ReadBytes(stored[0]);
                  Commit(tx, state);
                  return kept;
                });
  }

  // A real write (one small durable transaction), so that a server that
  // cannot write (or cannot be reached) shows.
  absl::Status Health() override {
    return Call("health", [&](pqxx::connection& conn, CallState& state) -> absl::Status {
      pqxx::work tx(conn);
      tx.exec0(
          "INSERT INTO store_info(key, value) VALUES('health', 1) "
          "ON CONFLICT (key) DO UPDATE SET value = store_info.value + 1");
      Commit(tx, state);
      return absl::OkStatus();
    });
  }

 private:
  // One snapshot of the database for all the queries of a load, so that a
  // PutSnapshot committing in between cannot pair an old snapshot with the
  // records after a new one.
  using ReadOnly = pqxx::transaction<pqxx::repeatable_read, pqxx::read_only>;

  // What a failure says about a write: once COMMIT is on its way, a lost
  // connection leaves the write's outcome unknown.
  struct CallState {
    bool committing = false;
  };

  static void Commit(pqxx::work& tx, CallState& state) {
    state.committing = true;
    tx.commit();
  }

  // One attempt of Init: Aborted when the database broke a deadlock by
  // rolling this transaction back.
  absl::Status InitOnce() {
    return Call("open", [&](pqxx::connection& conn, CallState& state) -> absl::Status {
      try {
        pqxx::work tx(conn);
        OAIPP_RETURN_IF_ERROR(postgres::BringSchemaUpToDate(tx));
        Commit(tx, state);
        return absl::OkStatus();
      } catch (const pqxx::deadlock_detected&) {
        return absl::AbortedError("store: open: deadlock detected");
      }
    });
  }

  // Runs `body(connection, state)` on a connection borrowed from `pool`
  // (the shared one by default; opened if the slot has none) and turns
  // whatever it throws into a status.
  template <typename Body>
  std::invoke_result_t<Body, pqxx::connection&, CallState&> Call(absl::string_view what,
                                                                 Body body) {
    return CallOn(pool_, what, std::move(body));
  }
  template <typename Body>
  std::invoke_result_t<Body, pqxx::connection&, CallState&> CallOn(ConnectionPool& pool,
                                                                   absl::string_view what,
                                                                   Body body) {
    using Result = std::invoke_result_t<Body, pqxx::connection&, CallState&>;
    std::unique_ptr<Connection> connection = pool.Borrow();
    if (connection != nullptr && !connection->Alive()) connection.reset();
    CallState state;
    Result result = [&]() -> Result {
      try {
        if (connection == nullptr) connection = std::make_unique<Connection>(uri_);
        return body(connection->get(), state);
      } catch (...) {
        return CurrentError(what, state.committing);
      }
    }();
    pool.Return(std::move(connection));
    return result;
  }

  const std::string uri_;
  ConnectionPool pool_;
  // The heartbeat's own connection: a server's "alive" never waits behind
  // its other calls, however busy the pool is.
  ConnectionPool heartbeat_pool_{1};
};

}  // namespace

absl::StatusOr<std::unique_ptr<MissionStore>> OpenPostgresStore(const std::string& uri,
                                                                int connections) {
  if (connections < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("store: open: connections must be at least 1, not ", connections));
  }
  auto store = std::make_unique<PostgresStore>(WithConnectTimeout(uri), connections);
  OAIPP_RETURN_IF_ERROR(store->Init());
  return store;
}

}  // namespace oaipp::server
