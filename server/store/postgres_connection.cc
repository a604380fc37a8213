#include "server/store/postgres_connection.h"

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

}  // namespace

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
