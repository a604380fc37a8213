#include "server/team_roster.h"

#include <algorithm>
#include <utility>

namespace oaipp::server {
namespace {

bool Holds(const std::vector<std::string>& ids, const std::string& uav_id) {
  return std::find(ids.begin(), ids.end(), uav_id) != ids.end();
}

}  // namespace

bool TeamRoster::Removed(const std::string& uav_id) const {
  absl::MutexLock lock(&mu_);
  return Holds(removed_, uav_id);
}

bool TeamRoster::Landed(const std::string& uav_id) const {
  absl::MutexLock lock(&mu_);
  return Holds(landed_, uav_id);
}

void TeamRoster::Remove(const std::string& uav_id, bool landed) {
  absl::MutexLock lock(&mu_);
  if (!Holds(removed_, uav_id)) removed_.push_back(uav_id);
  if (landed && !Holds(landed_, uav_id)) landed_.push_back(uav_id);
}

std::vector<std::string> TeamRoster::removed() const {
  absl::MutexLock lock(&mu_);
  return removed_;
}

std::vector<std::string> TeamRoster::landed() const {
  absl::MutexLock lock(&mu_);
  return landed_;
}

void TeamRoster::Restore(std::vector<std::string> removed, std::vector<std::string> landed) {
  absl::MutexLock lock(&mu_);
  removed_ = std::move(removed);
  landed_ = std::move(landed);
}

}  // namespace oaipp::server
