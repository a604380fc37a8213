#include "server/flight_track.h"

#include <algorithm>
#include <iterator>
#include <utility>

namespace oaipp::server {

void FlightTrack::Add(const std::string& uav_id, const Vec3& p_W, const std::vector<int>& detected,
                      const std::vector<Vec3>* planned_W) {
  absl::MutexLock lock(&mu_);
  MissionTrack& t = track_;
  MissionTrack::Uav& uav = t.uavs[uav_id];  // a member of the mission's team: checked before
  if (uav.flown_W.size() >= MissionTrack::kMaxFlown) {
    uav.flown_W.erase(uav.flown_W.begin(), uav.flown_W.begin() + MissionTrack::kMaxFlown / 4);
  }
  uav.flown_W.push_back(p_W);
  if (planned_W != nullptr) uav.planned_W = *planned_W;
  if (!detected.empty() && t.detected_cells.size() < MissionTrack::kMaxDetected) {
    std::vector<int> merged;
    std::set_union(t.detected_cells.begin(), t.detected_cells.end(), detected.begin(),
                   detected.end(), std::back_inserter(merged));
    if (merged.size() > MissionTrack::kMaxDetected) merged.resize(MissionTrack::kMaxDetected);
    t.detected_cells = std::move(merged);
  }
}

MissionTrack FlightTrack::Copy() const {
  absl::MutexLock lock(&mu_);
  return track_;
}

}  // namespace oaipp::server
