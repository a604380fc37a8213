// The store a server runs on, from its --store flag:
//   "memory"                  no store: missions are lost on restart (nullptr)
//   "sqlite"                  the embedded store, data_dir/missions.db (the folder is created)
//   "postgresql://..."        PostgreSQL, a libpq URI ("postgres://" too)
//
//   OAIPP_ASSIGN_OR_RETURN(std::unique_ptr<MissionStore> store, OpenStore("sqlite", "./data"));
#pragma once

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "server/store/mission_store.h"

namespace oaipp::server {

// InvalidArgument naming `store` for anything else; the backend's error when
// it cannot be opened.
[[nodiscard]] absl::StatusOr<std::unique_ptr<MissionStore>> OpenStore(const std::string& store,
                                                                      const std::string& data_dir);

// Where the store keeps its data, for a log line (a URI without its
// password).
[[nodiscard]] std::string DescribeStore(const std::string& store, const std::string& data_dir);

}  // namespace oaipp::server
