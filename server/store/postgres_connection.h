// What the PostgreSQL store (postgres_store.cc) needs of libpqxx beyond
// its queries: connections that keep the server's notices to themselves, a
// bounded pool of them that drops idle connections after a restart, and
// libpqxx's exceptions as statuses whose messages never quote stored bytes.
#pragma once

#include <poll.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <pqxx/pqxx>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/strings/escaping.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"

namespace oaipp::server::postgres {

// `uri` with connect_timeout=10 unless it names one: libpq then gives up on
// an unreachable host after that long instead of the TCP timeout (minutes),
// so a call that cannot connect soon gives its pool slot back.
[[nodiscard]] std::string WithConnectTimeout(const std::string& uri);

// The first line of a libpq or server message. The lines after it (DETAIL,
// the query) can quote stored values, and the store's messages never echo
// stored bytes.
[[nodiscard]] std::string FirstLine(absl::string_view message);

[[nodiscard]] absl::Status NoMission(absl::string_view what);

// libpqxx sends a std::string parameter as text, which libpq ends at the
// first NUL byte; a binarystring goes as a binary parameter, byte for byte.
inline pqxx::binarystring Blob(const std::string& bytes) { return pqxx::binarystring(bytes); }
inline std::string ReadBytes(const pqxx::field& field) { return pqxx::binarystring(field).str(); }

// A mission id as it appears in messages (ids are bytes to the store).
inline std::string Printable(absl::string_view id) { return absl::CHexEscape(id); }

// Unavailable, and maybe stored: the writer must read back before it writes
// again (mission_store.h).
[[nodiscard]] absl::Status InDoubt(absl::string_view what, absl::string_view cause);

// The status for the exception being handled (call only from a catch
// block). A refused key, a missing mission and a full disk have codes of
// their own; anything else means the store cannot be used now: Unavailable.
[[nodiscard]] absl::Status CurrentError(absl::string_view what, bool committing);

// A parameter of ExecBinary: its bytes, sent as they are (binary: a bytea
// byte for byte) or as text (a number in decimal).
struct Param {
  std::string value;
  bool binary = false;
};

// Runs `sql` inside the open transaction `tx` and returns its rows' values
// (nullopt for NULL) in PostgreSQL's binary format. libpqxx 6.4 asks for text
// results only, in which a bytea travels as hexadecimal: twice its size,
// encoded by the server and decoded here. Snapshots are megabytes, and
// a takeover waits for one, so they are read this way. Throws as libpqxx
// does (pqxx::broken_connection, pqxx::sql_error with the SQLSTATE), so
// CurrentError maps its failures like any other.
[[nodiscard]] std::vector<std::vector<std::optional<std::string>>> ExecBinary(
    const pqxx::dbtransaction& tx, const char* sql, const std::vector<Param>& params);

// One connection and the sink for its notices: libpqxx prints notices (the
// server's, and its own about transactions it aborts on a lost connection)
// to stderr unless a handler takes them, and the store reports through its
// statuses only.
class Connection {
 public:
  // Connects; throws pqxx::broken_connection when it cannot.
  explicit Connection(const std::string& uri) : conn_(uri), quiet_(conn_) {}
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  pqxx::connection& get() { return conn_; }

  // Whether the connection still looks usable, found without a round trip.
  // The store listens to no notifications, so an idle session hears from
  // the server only when it is being closed (shutdown, restart, a
  // terminated backend, an idle timeout): then its goodbye is waiting on the
  // socket. Such a connection is replaced before a call uses it, so a
  // restart of the server costs no failed call.
  bool Alive() noexcept {
    if (!conn_.is_open()) return false;
    pollfd socket = {.fd = conn_.sock(), .events = POLLIN, .revents = 0};
    return socket.fd >= 0 && poll(&socket, 1, /*timeout=*/0) == 0;
  }

 private:
  class Quiet final : public pqxx::errorhandler {
   public:
    explicit Quiet(pqxx::connection_base& conn) : pqxx::errorhandler(conn) {}
    bool operator()(const char[]) noexcept override { return false; }
  };

  pqxx::connection conn_;
  Quiet quiet_;  // declared after conn_: unregisters before the connection closes
};

// At most `size` connections in use at once. Each call borrows a slot; a
// free slot may keep an open connection for the next call.
class ConnectionPool {
 public:
  explicit ConnectionPool(int size) : free_(size) {}

  // Waits for a free slot and takes it, with its idle connection, or with
  // none (nullptr): the caller then opens one.
  std::unique_ptr<Connection> Borrow() {
    absl::MutexLock lock(&mu_);
    mu_.Await(absl::Condition(
        +[](int* slots) { return *slots > 0; }, &free_));
    --free_;
    if (idle_.empty()) return nullptr;
    std::unique_ptr<Connection> connection = std::move(idle_.back());
    idle_.pop_back();
    return connection;
  }

  // Gives the slot back, keeping `connection` for a later call while it is
  // open. A broken one (or none: opening failed) most likely means the server
  // restarted or went away, so the idle ones are dropped too rather than
  // failing one call each.
  void Return(std::unique_ptr<Connection> connection) {
    std::vector<std::unique_ptr<Connection>> dropped;
    absl::MutexLock lock(&mu_);
    ++free_;
    if (connection != nullptr && connection->get().is_open()) {
      idle_.push_back(std::move(connection));
    } else {
      dropped.swap(idle_);
    }
  }  // `lock` is released before `dropped` and `connection` close

 private:
  absl::Mutex mu_;
  int free_ ABSL_GUARDED_BY(mu_);
  std::vector<std::unique_ptr<Connection>> idle_ ABSL_GUARDED_BY(mu_);
};

}  // namespace oaipp::server::postgres
