#include "server/store/open_store.h"

#include <filesystem>

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
    const std::filesystem::path dir = data_dir;
    std::error_code error;
    std::filesystem::create_directories(dir, error);
    if (error) {
      return absl::UnavailableError(
          absl::StrCat("store: cannot create --data_dir ", dir.string(), ": ", error.message()));
    }
    return OpenSqliteStore((dir / "missions.db").string());
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
    // postgresql://user:secret@host -> postgresql://user:***@host
    std::string shown = store;
    const std::size_t user = shown.find("://") + 3;
    const std::size_t at = shown.find('@', user);
    if (at != std::string::npos) {
      const std::size_t colon = shown.find(':', user);
      if (colon < at) shown.replace(colon + 1, at - colon - 1, "***");
    }
    return absl::StrCat("postgresql ", shown);
  }
  return store;
}

}  // namespace oaipp::server
