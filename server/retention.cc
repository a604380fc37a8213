// Retention: a mission whose flight budget is spent, or that nobody has
// changed for long, is deleted with its records once the server's keep times
// pass, and old deletions' request_ids are forgotten, so that neither memory
// nor the store fills up with missions nobody flies.
#include "server/registry.h"

#include <algorithm>
#include <memory>
#include <string>
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

}  // namespace oaipp::server
