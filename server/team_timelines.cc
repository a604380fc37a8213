#include "server/team_timelines.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace oaipp::server {

absl::Status TeamTimelines::CheckStart(const std::string& uav_id, double start_s,
                                       double newest_s) const {
  if (const std::vector<PlannedPath>* own = Of(uav_id); own != nullptr) {
    const double held = own->back().team.start_mission_s;
    if (start_s < held) {
      return absl::FailedPreconditionError(absl::StrCat(
          "state.mission_time_s: ", start_s, " s is before the start of UAV '", uav_id,
          "''s plan the server holds (", held,
          " s): a plan may not rewrite what the UAV was already told to fly; send the state it "
          "is in now"));
    }
  }
  if (start_s < newest_s - kMaxLag_s) {
    return absl::FailedPreconditionError(
        absl::StrCat("state.mission_time_s: ", start_s, " s is more than ", kMaxLag_s,
                     " s behind the mission's newest time (", newest_s,
                     " s); send the state the UAV is in now"));
  }
  return absl::OkStatus();
}

void TeamTimelines::Commit(const PlannedPath& path, double newest_s) {
  std::vector<PlannedPath>& line = timelines_[path.team.uav_id];
  const double start = path.team.start_mission_s;
  // From `start` on, the new plan is in force: plans that would start at or
  // after it (none, when CheckStart passed) are no longer flown.
  line.erase(
      std::find_if(line.begin(), line.end(),
                   [start](const PlannedPath& p) { return p.team.start_mission_s >= start; }),
      line.end());
  line.push_back(path);
  // A plan is flown until the next one starts; once that is more than
  // kMaxLag_s behind, no plan the server still takes can meet it.
  const double oldest = newest_s - kMaxLag_s;
  std::size_t gone = 0;
  while (gone + 1 < line.size() && line[gone + 1].team.start_mission_s <= oldest) ++gone;
  line.erase(line.begin(), line.begin() + static_cast<std::ptrdiff_t>(gone));
}

const std::vector<PlannedPath>* TeamTimelines::Of(const std::string& uav_id) const {
  const auto it = timelines_.find(uav_id);
  return it == timelines_.end() || it->second.empty() ? nullptr : &it->second;
}

std::vector<PlannedPath> TeamTimelines::All() const {
  std::vector<PlannedPath> all;
  for (const auto& [uav_id, line] : timelines_) all.insert(all.end(), line.begin(), line.end());
  return all;
}

}  // namespace oaipp::server
