#include "server/registry.h"

#include <cmath>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/common/status_macros.h"

namespace oaipp::server {
namespace {

constexpr absl::string_view kPrefix = "missions/";

bool ValidId(absl::string_view id) {
  if (id.empty() || id.size() > 63) return false;
  for (char c : id) {
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-')) return false;
  }
  return true;
}

}  // namespace

absl::StatusOr<std::string> MissionRegistry::ParseName(absl::string_view name,
                                                       absl::string_view field) {
  if (!absl::StartsWith(name, kPrefix) || !ValidId(name.substr(kPrefix.size()))) {
    return absl::InvalidArgumentError(absl::StrCat(
        field, ": expected \"missions/{id}\" with id [a-z0-9-]{1,63}, got \"", name, "\""));
  }
  return std::string(name.substr(kPrefix.size()));
}

absl::StatusOr<std::shared_ptr<Mission>> MissionRegistry::Create(std::string mission_id,
                                                                 MissionConfig config,
                                                                 const std::string& request_id) {
  if (!mission_id.empty() && !ValidId(mission_id)) {
    return absl::InvalidArgumentError(
        absl::StrCat("mission_id: must match [a-z0-9-]{1,63}, got \"", mission_id, "\""));
  }
  const double nx = (config.field_max_W.x() - config.field_min_W.x()) / config.resolution_m;
  const double ny = (config.field_max_W.y() - config.field_min_W.y()) / config.resolution_m;
  const double cells = std::round(nx) * std::round(ny);
  if (cells > static_cast<double>(limits_.max_cells_per_mission)) {
    return absl::ResourceExhaustedError(absl::StrFormat(
        "spec.field: %.0f cells exceed this server's limit of %d per mission (the covariance "
        "would take %.0f MB); use a coarser resolution_m or a smaller field",
        cells, limits_.max_cells_per_mission, 8.0 * cells * cells / 1e6));
  }
  {
    absl::MutexLock lock(&mu_);
    if (const std::string* created = created_by_request_.Find(request_id)) {
      auto m = missions_.find(*created);
      if (m != missions_.end() && m->second != nullptr) return m->second;
      return absl::FailedPreconditionError(absl::StrCat("request_id: '", request_id,
                                                        "' created mission '", *created,
                                                        "', which is gone or still being built"));
    }
    if (mission_id.empty()) {
      do {
        mission_id = absl::StrFormat("m-%06d", next_id_++);
      } while (missions_.contains(mission_id));
    }
    if (missions_.contains(mission_id)) {
      return absl::AlreadyExistsError(
          absl::StrCat("mission_id: '", mission_id, "' already exists"));
    }
    if (static_cast<int>(missions_.size()) >= limits_.max_missions) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "this server holds its limit of ", limits_.max_missions, " missions; delete one first"));
    }
    missions_[mission_id] = nullptr;  // reserve the id while the map is built
  }
  absl::StatusOr<std::shared_ptr<Mission>> mission =
      Mission::Create(mission_id, std::move(config), priors_.get());
  absl::MutexLock lock(&mu_);
  if (!mission.ok()) {
    missions_.erase(mission_id);
    return mission.status();
  }
  missions_[mission_id] = *mission;
  order_.push_back(mission_id);
  if (!request_id.empty()) {
    created_by_request_.Remember(request_id, mission_id);
  }
  return mission;
}

absl::StatusOr<std::shared_ptr<Mission>> MissionRegistry::Get(absl::string_view name) const {
  OAIPP_ASSIGN_OR_RETURN(std::string id, ParseName(name));
  absl::MutexLock lock(&mu_);
  auto it = missions_.find(id);
  if (it == missions_.end() || it->second == nullptr) {
    return absl::NotFoundError(absl::StrCat("name: no mission '", name, "'"));
  }
  return it->second;
}

std::vector<std::shared_ptr<Mission>> MissionRegistry::List(std::size_t offset,
                                                            std::size_t limit) const {
  absl::MutexLock lock(&mu_);
  std::vector<std::shared_ptr<Mission>> out;
  for (std::size_t i = offset; i < order_.size() && out.size() < limit; ++i) {
    out.push_back(missions_.at(order_[i]));
  }
  return out;
}

absl::Status MissionRegistry::Delete(absl::string_view name, const std::string& request_id) {
  OAIPP_ASSIGN_OR_RETURN(std::string id, ParseName(name));
  std::shared_ptr<Mission> mission;
  {
    absl::MutexLock lock(&mu_);
    if (!request_id.empty()) {
      if (deleted_by_request_.Find(request_id) != nullptr) return absl::OkStatus();
    }
    auto it = missions_.find(id);
    if (it == missions_.end() || it->second == nullptr) {
      return absl::NotFoundError(absl::StrCat("name: no mission '", name, "'"));
    }
    mission = it->second;
    missions_.erase(it);
    std::erase(order_, id);
    if (!request_id.empty()) {
      deleted_by_request_.Remember(request_id, id);
    }
  }
  mission->MarkDeleted();
  return absl::OkStatus();
}

std::size_t MissionRegistry::size() const {
  absl::MutexLock lock(&mu_);
  return order_.size();
}

std::int64_t MissionRegistry::MemoryBytes() const {
  std::vector<std::shared_ptr<Mission>> all = List(0, static_cast<std::size_t>(-1));
  std::int64_t total = 0;
  for (const auto& m : all) total += m->MemoryBytes();
  return total;
}

}  // namespace oaipp::server
