// Reading missions back from the PostgreSQL store: LoadAll, Load and
// Claim share this (postgres_store.cc).
#include "server/store/postgres_load.h"

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "server/store/postgres_connection.h"

namespace oaipp::server::postgres {

absl::StatusOr<std::vector<StoredMission>> LoadMissions(pqxx::dbtransaction& tx,
                                                        const std::string* only,
                                                        std::int64_t have_through) {
  constexpr absl::string_view kMissions =
      "SELECT m.id, m.spec, m.request_id, m.fingerprint, m.create_time_us, "
      "s.sequence, s.write_time_us, m.epoch "
      "FROM missions m LEFT JOIN snapshots s ON s.mission_id = m.id ";
  constexpr absl::string_view kRecords =
      "SELECT r.mission_id, r.sequence, r.kind, r.payload, r.request_id, r.fingerprint, "
      "r.result, r.planner_state, r.write_time_us "
      "FROM records r JOIN missions m ON m.id = r.mission_id "
      "LEFT JOIN snapshots s ON s.mission_id = r.mission_id "
      "WHERE r.sequence > coalesce(s.sequence, 0) ";
  const pqxx::result missions =
      only == nullptr ? tx.exec(absl::StrCat(kMissions, "ORDER BY m.create_time_us, m.id"))
                      : tx.exec_params(absl::StrCat(kMissions, "WHERE m.id = $1"), Blob(*only));
  std::vector<StoredMission> out;
  out.reserve(missions.size());
  for (const pqxx::row& row : missions) {
    StoredMission& m =
        out.emplace_back(StoredMission{.id = ReadBytes(row[0]),
                                       .spec = ReadBytes(row[1]),
                                       .request_id = ReadBytes(row[2]),
                                       .fingerprint = ReadBytes(row[3]),
                                       .create_time_unix_us = row[4].as<std::int64_t>(),
                                       .epoch = row[7].as<std::int64_t>()});
    // A snapshot the reader holds already is not read (megabytes).
    if (!row[5].is_null() && row[5].as<std::int64_t>() > have_through) {
      m.snapshot = StoredSnapshot{.sequence = row[5].as<std::int64_t>(),
                                  .write_time_unix_us = row[6].as<std::int64_t>()};
      // The state in binary (megabytes: hex would double them), in the
      // same transaction; the sequence pins the row read above.
      auto state = ExecBinary(
          tx, "SELECT state FROM snapshots WHERE mission_id = $1 AND sequence = $2::bigint",
          {{.value = m.id, .binary = true}, {.value = absl::StrCat(m.snapshot->sequence)}});
      if (state.size() != 1 || !state[0][0].has_value()) {
        return absl::UnavailableError(absl::StrCat("store: load: the snapshot of '",
                                                   Printable(m.id), "' changed while read; retry"));
      }
      m.snapshot->state = *std::move(state[0][0]);
    }
  }
  const pqxx::result records =
      only == nullptr
          ? tx.exec(absl::StrCat(kRecords, "ORDER BY m.create_time_us, m.id, r.sequence"))
          : tx.exec_params(absl::StrCat(kRecords, "AND m.id = $1 ORDER BY r.sequence"),
                           Blob(*only));
  // Both results come in the same mission order: one walk pairs them.
  std::size_t i = 0;
  for (const pqxx::row& row : records) {
    const std::string mission_id = ReadBytes(row[0]);
    while (i < out.size() && out[i].id != mission_id) ++i;
    if (i == out.size()) {
      return absl::InternalError(
          absl::StrCat("store: load: a record of '", Printable(mission_id), "' out of order"));
    }
    out[i].log.push_back({.sequence = row[1].as<std::int64_t>(),
                          .kind = static_cast<RecordKind>(row[2].as<int>()),
                          .payload = ReadBytes(row[3]),
                          .request_id = ReadBytes(row[4]),
                          .fingerprint = ReadBytes(row[5]),
                          .result = ReadBytes(row[6]),
                          .planner_state = ReadBytes(row[7]),
                          .write_time_unix_us = row[8].as<std::int64_t>()});
  }
  for (StoredMission& m : out) KeepOnlyAfter(m, have_through);
  return out;
}

}  // namespace oaipp::server::postgres
