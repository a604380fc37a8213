#include "server/store/postgres_connection.h"

#include <libpq-fe.h>

#include <exception>
#include <string>

#include "absl/strings/ascii.h"
#include "absl/strings/cord.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "server/store/mission_store.h"

namespace oaipp::server::postgres {
namespace {

constexpr absl::string_view kConnectTimeout = "connect_timeout=10";

// libpqxx 6.4 keeps a transaction's libpq connection to itself; its large
// object class hands it to subclasses, for calls libpqxx does not wrap.
class RawConnection : public pqxx::largeobject {
 public:
  static PGconn* Of(const pqxx::dbtransaction& tx) { return raw_connection(tx); }
};

using ResultPtr = std::unique_ptr<PGresult, decltype(&PQclear)>;

}  // namespace

std::vector<std::vector<std::optional<std::string>>> ExecBinary(const pqxx::dbtransaction& tx,
                                                                const char* sql,
                                                                const std::vector<Param>& params) {
  PGconn* conn = RawConnection::Of(tx);
  std::vector<const char*> values;
  std::vector<int> lengths, formats;
  for (const Param& p : params) {
    values.push_back(p.value.c_str());  // text parameters end at their NUL
    lengths.push_back(static_cast<int>(p.value.size()));
    formats.push_back(p.binary ? 1 : 0);
  }
  const ResultPtr result(PQexecParams(conn, sql, static_cast<int>(params.size()), nullptr,
                                      values.data(), lengths.data(), formats.data(),
                                      /*resultFormat=*/1),
                         &PQclear);
  if (result == nullptr || PQstatus(conn) != CONNECTION_OK) {
    throw pqxx::broken_connection(PQerrorMessage(conn));
  }
  if (PQresultStatus(result.get()) != PGRES_TUPLES_OK) {
    const char* sqlstate = PQresultErrorField(result.get(), PG_DIAG_SQLSTATE);
    throw pqxx::sql_error(PQresultErrorMessage(result.get()), sql,
                          sqlstate != nullptr ? sqlstate : "");
  }
  std::vector<std::vector<std::optional<std::string>>> rows(
      static_cast<std::size_t>(PQntuples(result.get())));
  for (int r = 0; r < PQntuples(result.get()); ++r) {
    for (int c = 0; c < PQnfields(result.get()); ++c) {
      if (PQgetisnull(result.get(), r, c)) {
        rows[r].emplace_back(std::nullopt);
      } else {
        rows[r].emplace_back(
            std::string(PQgetvalue(result.get(), r, c),
                        static_cast<std::size_t>(PQgetlength(result.get(), r, c))));
      }
    }
  }
  return rows;
}

std::string WithConnectTimeout(const std::string& uri) {
  if (absl::StrContains(uri, "connect_timeout")) return uri;
  if (absl::StartsWith(uri, "postgresql://") || absl::StartsWith(uri, "postgres://")) {
    return absl::StrCat(uri, absl::StrContains(uri, '?') ? "&" : "?", kConnectTimeout);
  }
  return absl::StrCat(uri, " ", kConnectTimeout);
}

std::string FirstLine(absl::string_view message) {
  message = message.substr(0, message.find('\n'));
  absl::ConsumePrefix(&message, "ERROR:  ");
  return std::string(absl::StripTrailingAsciiWhitespace(message));
}

absl::Status NoMission(absl::string_view what) {
  return absl::NotFoundError(absl::StrCat("store: ", what, ": no such mission"));
}

absl::Status InDoubt(absl::string_view what, absl::string_view cause) {
  std::string message = absl::StrCat(
      "store: ", what, ": connection lost while committing, the write may or may not be stored");
  if (!cause.empty()) absl::StrAppend(&message, " (", FirstLine(cause), ")");
  absl::Status status = absl::UnavailableError(message);
  status.SetPayload(kInDoubt, absl::Cord("1"));
  return status;
}

absl::Status CurrentError(absl::string_view what, bool committing) {
  try {
    throw;
  } catch (const pqxx::in_doubt_error&) {
    return InDoubt(what, "");  // its text says no more than InDoubt's
  } catch (const pqxx::broken_connection& e) {
    // libpqxx itself turns a connection lost during COMMIT into
    // in_doubt_error; this keeps a loss it reports otherwise on the safe side.
    if (committing) return InDoubt(what, e.what());
    return absl::UnavailableError(
        absl::StrCat("store: ", what, ": no connection (", FirstLine(e.what()), ")"));
  } catch (const pqxx::unique_violation& e) {
    return absl::AlreadyExistsError(absl::StrCat("store: ", what, ": ", FirstLine(e.what())));
  } catch (const pqxx::foreign_key_violation&) {
    return NoMission(what);
  } catch (const pqxx::disk_full& e) {
    return absl::ResourceExhaustedError(
        absl::StrCat("store: ", what, ": database disk full (", FirstLine(e.what()), ")"));
  } catch (const pqxx::sql_error& e) {
    return absl::UnavailableError(
        absl::StrCat("store: ", what, ": ", FirstLine(e.what()), " (SQLSTATE ", e.sqlstate(), ")"));
  } catch (const std::exception& e) {
    return absl::UnavailableError(absl::StrCat("store: ", what, ": ", FirstLine(e.what())));
  } catch (...) {
    return absl::UnavailableError(absl::StrCat("store: ", what, ": unknown error"));
  }
}

}  // namespace oaipp::server::postgres
