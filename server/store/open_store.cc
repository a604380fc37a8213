#include "server/store/open_store.h"

#include <fcntl.h>
#include <unistd.h>

#include <filesystem>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "server/store/postgres_store.h"
#include "server/store/sqlite_store.h"

namespace oaipp::server {
namespace {

bool IsPostgresUri(const std::string& store) {
  return absl::StartsWith(store, "postgresql://") || absl::StartsWith(store, "postgres://");
}

}  // namespace

absl::StatusOr<std::unique_ptr<MissionStore>> OpenStore(const std::string& store,
                                                        const std::string& data_dir) {
  if (store == "memory") return std::unique_ptr<MissionStore>();
  if (store == "sqlite") {
    // Missions are the operator's data: a --data_dir this creates is the
    // owner's alone (0700), and so is the database (0600; SQLite gives its
    // WAL and shared-memory files the database's mode).
    const std::filesystem::path dir = data_dir;
    std::error_code error;
    const bool created = std::filesystem::create_directories(dir, error);
    if (!error && created) {
      std::filesystem::permissions(dir, std::filesystem::perms::owner_all,
                                   std::filesystem::perm_options::replace, error);
    }
    if (error) {
      return absl::UnavailableError(
          absl::StrCat("store: cannot create --data_dir ", dir.string(), ": ", error.message()));
    }
    const std::filesystem::path db = dir / "missions.db";
    if (const int fd = ::open(db.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600); fd >= 0) {
      ::close(fd);
    }
    return OpenSqliteStore(db.string());
  }
  if (IsPostgresUri(store)) return OpenPostgresStore(store);
  return absl::InvalidArgumentError(
      absl::StrCat("store: must be memory, sqlite or a postgresql:// URI, got '",
                   store.substr(0, 64), store.size() > 64 ? "...'" : "'"));
}

std::string DescribeStore(const std::string& store, const std::string& data_dir) {
  if (store == "sqlite") {
    return absl::StrCat("sqlite file ", (std::filesystem::path(data_dir) / "missions.db").string());
  }
  if (IsPostgresUri(store)) {
    // postgresql://user:secret@host/db?password=x -> the secrets as ***.
    std::string shown = store;
    const std::size_t user = shown.find("://") + 3;
    const std::size_t slash = std::min(shown.find('/', user), shown.find('?', user));
    const std::size_t at = shown.rfind('@', slash);
    if (at != std::string::npos && at >= user) {
      const std::size_t colon = shown.find(':', user);
      if (colon < at) shown.replace(colon + 1, at - colon - 1, "***");
    }
    for (std::size_t key = shown.find('?'); key != std::string::npos;
         key = shown.find('&', key + 1)) {
      const std::size_t equals = shown.find('=', key);
      if (equals == std::string::npos) break;
      const std::string name = absl::AsciiStrToLower(shown.substr(key + 1, equals - key - 1));
      if (name == "password" || name == "sslpassword") {
        const std::size_t end = std::min(shown.find('&', equals), shown.size());
        shown.replace(equals + 1, end - equals - 1, "***");
      }
    }
    return absl::StrCat("postgresql ", shown);
  }
  return store;
}

}  // namespace oaipp::server
