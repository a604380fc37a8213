// Retention: a mission whose flight budget is spent, or that nobody has
// changed for long, is deleted with its records once the server's keep times
// pass, and old deletions' request_ids are forgotten, so that neither memory
// nor the store fills up with missions nobody flies.
#include "server/registry.h"

#include <algorithm>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "spdlog/spdlog.h"

namespace oaipp::server {

std::vector<std::string> MissionRegistry::Sweep(absl::Time now, absl::Duration keep_finished,
                                                absl::Duration keep_idle) {
  std::vector<std::string> expired;
  for (const std::shared_ptr<Mission>& m : List(0, static_cast<std::size_t>(-1))) {
    const absl::Duration unchanged = now - m->last_change_time();
    if (unchanged >= keep_idle || (unchanged >= keep_finished && m->finished())) {
      expired.push_back(m->id());
    }
  }
  std::vector<std::string> deleted;
  for (const std::string& id : expired) {
    const absl::Status status = DeleteKey(id, "", "");
    if (status.ok()) {
      deleted.push_back(id);
    } else if (status.code() != absl::StatusCode::kNotFound) {
      spdlog::warn("retention: cannot delete mission '{}': {}", id, status.ToString());
    }
  }
  if (store_ != nullptr) {
    const absl::Duration keep = std::max(keep_finished, keep_idle);
    if (keep != absl::InfiniteDuration()) {
      if (absl::Status s = store_->ForgetDeletionsBefore(absl::ToUnixMicros(now - keep)); !s.ok()) {
        spdlog::warn("retention: {}", s.ToString());
      }
    }
  }
  return deleted;
}

std::vector<std::string> MissionRegistry::SweepStore(absl::Time now, absl::Duration keep_idle,
                                                     const std::string& holder,
                                                     absl::Duration lease) {
  std::vector<std::string> deleted;
  if (!shares_store() || keep_idle == absl::InfiniteDuration()) return deleted;
  const absl::StatusOr<bool> held = store_->TryLease("retention", holder, absl::ToUnixMicros(now),
                                                     absl::ToUnixMicros(now + lease), false);
  if (!held.ok()) {
    spdlog::warn("retention: {}", held.status().ToString());
    return deleted;
  }
  if (!*held) return deleted;
  absl::StatusOr<std::vector<std::pair<std::string, std::int64_t>>> idle =
      store_->IdleSince(absl::ToUnixMicros(now - keep_idle), 100);
  if (!idle.ok()) {
    spdlog::warn("retention: {}", idle.status().ToString());
    return deleted;
  }
  for (const auto& [id, epoch] : *idle) {
    // A copy held here goes with its store rows; another server's copy
    // finds the mission gone at its next call (Hold) or its next check
    // (DropMoved). A mission claimed since it was read has another epoch
    // and is left (fenced).
    std::shared_ptr<Mission> here = Find(id);
    const absl::Status status = here != nullptr && here->lease().epoch() == epoch
                                    ? DeleteKey(id, "", "")
                                    : store_->DeleteMission(id, "", epoch);
    if (status.ok()) {
      deleted.push_back(id);
    } else if (status.code() != absl::StatusCode::kNotFound && !status.GetPayload(kFenced)) {
      spdlog::warn("retention: cannot delete mission '{}': {}", id, status.ToString());
    }
  }
  return deleted;
}

}  // namespace oaipp::server
