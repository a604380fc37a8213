#include "server/mission_names.h"

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "api/status.h"

namespace oaipp::server {

bool ValidMissionId(absl::string_view id) {
  if (id.empty() || id.size() > 63) return false;
  for (char c : id) {
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-')) return false;
  }
  return true;
}

std::string MissionKey(absl::string_view tenant, absl::string_view id) {
  return tenant.empty() ? std::string(id) : absl::StrCat(tenant, "/", id);
}

absl::string_view PublicId(absl::string_view key) {
  const std::size_t slash = key.find('/');
  return slash == absl::string_view::npos ? key : key.substr(slash + 1);
}

absl::string_view TenantOfKey(absl::string_view key) {
  const std::size_t slash = key.find('/');
  return slash == absl::string_view::npos ? absl::string_view() : key.substr(0, slash);
}

std::string MissionName(absl::string_view key) {
  return absl::StrCat(kMissionNamePrefix, PublicId(key));
}

absl::StatusOr<std::string> ParseMissionName(absl::string_view name, absl::string_view field) {
  if (!absl::StartsWith(name, kMissionNamePrefix) ||
      !ValidMissionId(name.substr(kMissionNamePrefix.size()))) {
    return absl::InvalidArgumentError(absl::StrCat(
        field, ": expected \"missions/{id}\" with id [a-z0-9-]{1,63}, got ", api::EchoInput(name)));
  }
  return std::string(name.substr(kMissionNamePrefix.size()));
}

}  // namespace oaipp::server
