// How the server names a mission: "missions/{id}" in the API, and its key
// in the registry and the store, the id prefixed by "tenant/" for a named
// tenant (so the anonymous tenant's keys are the bare ids).
//
//   MissionKey("acme", "m1") == "acme/m1";  PublicId("acme/m1") == "m1"
//   OAIPP_ASSIGN_OR_RETURN(std::string id, ParseMissionName("missions/m1"));
#pragma once

#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace oaipp::server {

// A mission's name is kMissionNamePrefix followed by its id.
inline constexpr absl::string_view kMissionNamePrefix = "missions/";

// True for an id the API accepts: [a-z0-9-]{1,63}.
[[nodiscard]] bool ValidMissionId(absl::string_view id);
[[nodiscard]] std::string MissionKey(absl::string_view tenant, absl::string_view id);
// The id part of a key (what the tenant calls the mission).
[[nodiscard]] absl::string_view PublicId(absl::string_view key);
[[nodiscard]] absl::string_view TenantOfKey(absl::string_view key);
// "missions/{id}" for the mission under `key`.
[[nodiscard]] std::string MissionName(absl::string_view key);
// "missions/{id}" -> id, or InvalidArgument naming `field`.
[[nodiscard]] absl::StatusOr<std::string> ParseMissionName(absl::string_view name,
                                                           absl::string_view field = "name");

}  // namespace oaipp::server
