// A mission's team (docs/teams.md): the checks on a UAV that asks for a
// plan, and taking a member out (RemoveMember). Each member's planner and
// the teammates a plan keeps clear of are MissionPlanning's.
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"
#include "server/mission.h"

namespace oaipp::server {

absl::Status Mission::CheckPlanningUav(const std::string& uav_id) const {
  OAIPP_RETURN_IF_ERROR(config_.CheckUavId(uav_id, "uav_id"));
  if (roster_.Removed(uav_id)) {
    return absl::NotFoundError(
        absl::StrCat("uav_id: UAV '", uav_id, "' was removed from the team"));
  }
  return absl::OkStatus();
}

absl::StatusOr<TeamResult> Mission::RemoveMember(const std::string& uav_id, bool landed,
                                                 const RequestKey& request,
                                                 const PersistFn& persist) {
  // No plan is in progress while the team changes, and the change takes
  // its place in the log's order as mutations do.
  MissionPlanning::Held planning(planning_);
  absl::MutexLock order(&mutation_mu_);
  if (auto done = answers_.Recall<TeamResult>(request)) return *std::move(done);
  if (config_.team.empty()) {
    return absl::FailedPreconditionError(
        "uav_id: the mission flies one UAV without a team; there is no member to remove");
  }
  OAIPP_RETURN_IF_ERROR(config_.CheckUavId(uav_id, "uav_id"));
  // A UAV removed in the air may be reported landed later; nothing else
  // about a removed UAV changes.
  const bool removed = roster_.Removed(uav_id);
  if (removed && (!landed || roster_.Landed(uav_id))) {
    return absl::FailedPreconditionError(absl::StrCat(
        "uav_id: UAV '", uav_id, "' was removed from the team already",
        roster_.Landed(uav_id) ? " and has landed" : "; only landed: true may follow"));
  }
  TeamResult result;
  for (const api::TeamMember& member : config_.team) {
    if (member.uav_id != uav_id && !roster_.Removed(member.uav_id)) {
      result.flying_uav_ids.push_back(member.uav_id);
    }
  }
  if (result.flying_uav_ids.empty() && !removed) {
    return absl::FailedPreconditionError(absl::StrCat(
        "uav_id: UAV '", uav_id, "' is the last one in the team; delete the mission instead"));
  }
  // Durable first: a failed write leaves the team as it was.
  OAIPP_RETURN_IF_ERROR(Persist(persist));
  roster_.Remove(uav_id, landed);
  // In the air it stays an obstacle on its timeline (TeammatesOf); landed,
  // it is gone.
  if (landed) planning.timelines().Erase(uav_id);
  planning.ErasePlanner(uav_id);
  answers_.Remember(request, result);
  if (!removed) events_.Emit(MissionEventData::MemberRemoved{uav_id});
  MaybeWantSnapshot();
  return result;
}

}  // namespace oaipp::server
