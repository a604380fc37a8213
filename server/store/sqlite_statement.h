// SQLite's C API as the SQLite store uses it: statuses for failed calls and
// prepared statements that finalize themselves. Internal to server/store/.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"

namespace oaipp::server::sqlite {

// The status for a failed SQLite call: a full disk is ResourceExhausted, a
// violated key AlreadyExists, anything else Unavailable (the store, not the
// request, is at fault).
inline absl::Status SqliteError(sqlite3* db, int code, absl::string_view what) {
  const std::string message = absl::StrCat("store: ", what, ": ", sqlite3_errmsg(db));
  switch (code & 0xff) {
    case SQLITE_FULL:
      return absl::ResourceExhaustedError(message);
    case SQLITE_CONSTRAINT:
      return absl::AlreadyExistsError(message);
    default:
      return absl::UnavailableError(message);
  }
}

// Runs `sql` (statements without results); the error names `what`.
inline absl::Status Exec(sqlite3* db, const char* sql, absl::string_view what) {
  const int code = sqlite3_exec(db, sql, nullptr, nullptr, nullptr);
  return code == SQLITE_OK ? absl::OkStatus() : SqliteError(db, code, what);
}

// A prepared statement, finalized when it goes out of scope.
class Statement {
 public:
  Statement(sqlite3* db, const char* sql) : db_(db) {
    code_ = sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr);
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  [[nodiscard]] absl::Status prepared(absl::string_view what) const {
    return code_ == SQLITE_OK ? absl::OkStatus() : SqliteError(db_, code_, what);
  }
  void Bind(int i, const std::string& bytes, bool blob = false) {
    if (blob) {
      sqlite3_bind_blob(stmt_, i, bytes.data(), static_cast<int>(bytes.size()), SQLITE_TRANSIENT);
    } else {
      sqlite3_bind_text(stmt_, i, bytes.data(), static_cast<int>(bytes.size()), SQLITE_TRANSIENT);
    }
  }
  void Bind(int i, std::int64_t value) { sqlite3_bind_int64(stmt_, i, value); }
  // SQLITE_ROW, SQLITE_DONE or an error code.
  int Step() { return sqlite3_step(stmt_); }
  // Steps a statement that returns no row: OK on SQLITE_DONE, else the
  // error, naming `what`.
  [[nodiscard]] absl::Status Done(absl::string_view what) {
    const int code = Step();
    return code == SQLITE_DONE ? absl::OkStatus() : SqliteError(db_, code, what);
  }
  [[nodiscard]] std::string Bytes(int column) const {
    const void* data = sqlite3_column_blob(stmt_, column);
    const int size = sqlite3_column_bytes(stmt_, column);
    return data == nullptr ? std::string() : std::string(static_cast<const char*>(data), size);
  }
  [[nodiscard]] std::int64_t Int(int column) const { return sqlite3_column_int64(stmt_, column); }

 private:
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
  int code_ = SQLITE_OK;
};

}  // namespace oaipp::server::sqlite
