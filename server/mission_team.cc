// A mission's team (docs/teams.md): each member's planner with its own
// limits, the checks on a UAV that asks for a plan, taking a member out
// (RemoveMember), and the teammates a plan keeps clear of (TeammatesOf).
#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "core/common/status_macros.h"
#include "server/mission.h"

namespace oaipp::server {

absl::StatusOr<Planner*> Mission::PlannerOf(const std::string& uav_id) {
  if (config_.team.empty()) return planner_.get();
  // A team's kinds (OA-IPP, random) keep no state between plans, so each
  // member's planner, made with its own limits when first asked, plans as
  // the mission's would with those limits.
  std::unique_ptr<Planner>& own = member_planners_[uav_id];
  if (own == nullptr) {
    OAIPP_ASSIGN_OR_RETURN(own, MakePlanner(config_.PlannerFor(uav_id)));
  }
  return own.get();
}

absl::Status Mission::NamedForMember(const absl::Status& status, const std::string& uav_id) const {
  for (std::size_t i = 0; i < config_.team.size(); ++i) {
    if (config_.team[i].uav_id != uav_id) continue;
    // A member's limits are its own (spec.team[i].flight): a plan's error
    // names that field, not the mission's (api::WithApiFieldNames).
    const std::string own = absl::StrCat("spec.team[", i, "].flight.");
    absl::Status out(
        status.code(),
        absl::StrReplaceAll(status.message(), {{"limits.max_speed_m_s", own + "max_speed_m_s"},
                                               {"limits.max_accel_m_s2", own + "max_accel_m_s2"},
                                               {"limits.uav_radius_m", own + "uav_radius_m"}}));
    status.ForEachPayload(
        [&](absl::string_view url, const absl::Cord& payload) { out.SetPayload(url, payload); });
    return out;
  }
  return status;
}

absl::Status Mission::CheckPlanningUav(const std::string& uav_id) const {
  OAIPP_RETURN_IF_ERROR(config_.CheckUavId(uav_id, "uav_id"));
  if (Removed(uav_id)) {
    return absl::NotFoundError(
        absl::StrCat("uav_id: UAV '", uav_id, "' was removed from the team"));
  }
  return absl::OkStatus();
}

bool Mission::Removed(const std::string& uav_id) const {
  absl::MutexLock lock(&summary_mu_);
  return std::find(removed_.begin(), removed_.end(), uav_id) != removed_.end();
}

absl::StatusOr<TeamResult> Mission::RemoveMember(const std::string& uav_id,
                                                 const RequestKey& request,
                                                 const PersistFn& persist) {
  // No plan is in progress while the team changes, and the change takes
  // its place in the log's order as mutations do.
  absl::MutexLock planner_lock(&planner_mu_);
  absl::MutexLock order(&mutation_mu_);
  if (auto done = answers_.Recall<TeamResult>(request)) return *std::move(done);
  if (config_.team.empty()) {
    return absl::FailedPreconditionError(
        "uav_id: the mission flies one UAV without a team; there is no member to remove");
  }
  OAIPP_RETURN_IF_ERROR(config_.CheckUavId(uav_id, "uav_id"));
  if (Removed(uav_id)) {
    return absl::FailedPreconditionError(
        absl::StrCat("uav_id: UAV '", uav_id, "' was removed from the team already"));
  }
  TeamResult result;
  for (const api::TeamMember& member : config_.team) {
    if (member.uav_id != uav_id && !Removed(member.uav_id)) {
      result.flying_uav_ids.push_back(member.uav_id);
    }
  }
  if (result.flying_uav_ids.empty()) {
    return absl::FailedPreconditionError(absl::StrCat(
        "uav_id: UAV '", uav_id, "' is the last one in the team; delete the mission instead"));
  }
  // Durable first: a failed write leaves the team as it was.
  OAIPP_RETURN_IF_ERROR(Persist(persist));
  {
    absl::MutexLock lock(&summary_mu_);
    removed_.push_back(uav_id);
  }
  committed_.erase(uav_id);
  member_planners_.erase(uav_id);
  answers_.Remember(request, result);
  events_.Emit(MissionEventData::MemberRemoved{uav_id});
  MaybeWantSnapshot();
  return result;
}

std::vector<Teammate> Mission::TeammatesOf(
    const std::string& uav_id, double now_s, const std::map<std::string, double>& last_shot_s,
    std::vector<std::pair<std::string, std::int64_t>>* versions) const {
  std::vector<Teammate> mates;
  for (const api::TeamMember& member : config_.team) {
    if (member.uav_id == uav_id || Removed(member.uav_id)) continue;
    if (auto it = committed_.find(member.uav_id); it != committed_.end()) {
      const PlannedPath& path = it->second;
      // A shot at now_s may have been taken and fused already (teammates
      // shoot on one clock and plan at their shots): then it is in the map,
      // and counting it again would take its ground as seen twice. A
      // camera's own clock may stamp a shot a little before or after its
      // planned time, so a shot within half a period after the teammate's
      // latest measurement counts as that measurement.
      const auto fused = last_shot_s.find(member.uav_id);
      const double half_period_s = 0.5 / member.kit.camera.rate_hz;
      std::vector<Vec3> pending;
      for (const MeasurementPose& shot : path.measurement_poses) {
        if (config_.count_teammate_shots && shot.mission_time_s >= now_s &&
            (fused == last_shot_s.end() || shot.mission_time_s > fused->second + half_period_s)) {
          pending.push_back(shot.position_W);
        }
      }
      mates.push_back({.uav_id = member.uav_id,
                       .trajectory = path.trajectory,
                       .start_mission_s = path.team.start_mission_s,
                       .pending_shots_W = std::move(pending),
                       .camera = member.kit.camera,
                       .noise = member.kit.noise});
      versions->emplace_back(member.uav_id, path.team.plan_version);
      continue;
    }
    // Not planned yet: held at its start (a one-point trajectory).
    PolynomialTrajectory::SegmentCoefficients c = PolynomialTrajectory::SegmentCoefficients::Zero();
    c.row(0) = member.start.position_W.transpose();
    mates.push_back({.uav_id = member.uav_id,
                     .trajectory = *PolynomialTrajectory::FromCoefficients({1.0}, {c}),
                     .start_mission_s = member.start.mission_time_s});
    versions->emplace_back(member.uav_id, 0);
  }
  std::sort(versions->begin(), versions->end());
  return mates;
}

}  // namespace oaipp::server
