#include "server/fused_shots.h"

#include <algorithm>
#include <utility>

namespace oaipp::server {

void FusedShots::Add(const std::string& uav_id, double t_s) {
  std::vector<double>& times = shots_[uav_id].times_s;
  times.insert(std::upper_bound(times.begin(), times.end(), t_s), t_s);
}

bool FusedShots::Fused(const std::string& uav_id, double t_s, double half_period_s) const {
  const auto it = shots_.find(uav_id);
  if (it == shots_.end()) return false;
  const Shots& s = it->second;
  if (t_s <= s.fused_through_s + half_period_s) return true;
  const auto near = std::lower_bound(s.times_s.begin(), s.times_s.end(), t_s - half_period_s);
  return near != s.times_s.end() && *near <= t_s + half_period_s;
}

double FusedShots::Latest(const std::string& uav_id) const {
  const auto it = shots_.find(uav_id);
  if (it == shots_.end()) return -std::numeric_limits<double>::infinity();
  const Shots& s = it->second;
  return s.times_s.empty() ? s.fused_through_s : std::max(s.fused_through_s, s.times_s.back());
}

void FusedShots::Prune(double t_s) {
  for (auto& [uav_id, s] : shots_) {
    // The latest stays: it says when the UAV last reported.
    const auto keep_from = std::min(std::lower_bound(s.times_s.begin(), s.times_s.end(), t_s),
                                    s.times_s.empty() ? s.times_s.end() : s.times_s.end() - 1);
    s.times_s.erase(s.times_s.begin(), keep_from);
  }
}

std::map<std::string, std::vector<double>> FusedShots::Times() const {
  std::map<std::string, std::vector<double>> out;
  for (const auto& [uav_id, s] : shots_) out[uav_id] = s.times_s;
  return out;
}

void FusedShots::Restore(std::map<std::string, std::vector<double>> times,
                         const std::map<std::string, double>& legacy_latest) {
  shots_.clear();
  for (auto& [uav_id, t] : times) {
    std::sort(t.begin(), t.end());
    shots_[uav_id].times_s = std::move(t);
  }
  for (const auto& [uav_id, latest] : legacy_latest) {
    Shots& s = shots_[uav_id];
    if (s.times_s.empty()) s.fused_through_s = latest;
  }
}

}  // namespace oaipp::server
