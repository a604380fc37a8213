// A mission's team (docs/teams.md): each member's planner with its own
// limits, the checks on a UAV that asks for a plan, taking a member out
// (RemoveMember), and the teammates a plan keeps clear of (TeammatesOf).
#include <algorithm>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "api/status.h"
#include "core/common/status_macros.h"
#include "server/mission.h"

namespace oaipp::server {
namespace {

// A UAV that has not planned yet, held at its start: a one-point trajectory.
PolynomialTrajectory HeldAt(const UavState& start) {
  PolynomialTrajectory::SegmentCoefficients c = PolynomialTrajectory::SegmentCoefficients::Zero();
  c.row(0) = start.position_W.transpose();
  return *PolynomialTrajectory::FromCoefficients({1.0}, {c});
}

}  // namespace

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
    // A member's limits are its own (spec.team[i].flight): a plan's error
    // names that field, not the mission's.
    if (config_.team[i].uav_id == uav_id) {
      return api::WithApiFieldNames(status, static_cast<int>(i));
    }
  }
  return status;
}

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
  absl::MutexLock planner_lock(&planner_mu_);
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
  if (landed) timelines_.Erase(uav_id);
  member_planners_.erase(uav_id);
  answers_.Remember(request, result);
  if (!removed) events_.Emit(MissionEventData::MemberRemoved{uav_id});
  MaybeWantSnapshot();
  return result;
}

std::vector<Teammate> Mission::TeammatesOf(
    const std::string& uav_id, double now_s, double newest_s, const FusedShots& fused,
    std::vector<std::pair<std::string, std::int64_t>>* versions) const {
  std::vector<Teammate> mates;
  for (const api::TeamMember& member : config_.team) {
    if (member.uav_id == uav_id || roster_.Landed(member.uav_id)) continue;
    const bool removed = roster_.Removed(member.uav_id);
    const std::vector<PlannedPath>* line = timelines_.Of(member.uav_id);
    Teammate mate{.uav_id = member.uav_id,
                  .trajectory = line != nullptr ? line->back().trajectory : HeldAt(member.start),
                  .start_mission_s = line != nullptr ? line->back().team.start_mission_s
                                                     : member.start.mission_time_s,
                  .min_distance_m = config_.PairDistance(uav_id, member.uav_id),
                  .camera = member.kit.camera,
                  .noise = member.kit.noise};
    double last_report_s = mate.start_mission_s;
    std::int64_t version = 0;
    if (line != nullptr) {
      for (std::size_t i = 0; i + 1 < line->size(); ++i) {
        mate.earlier.push_back({(*line)[i].trajectory, (*line)[i].team.start_mission_s});
      }
      version = line->back().team.plan_version;
      // Its shots still to come, each on the plan in force when it is
      // taken, and not in the map yet: a shot at now_s may have been taken
      // and fused already (teammates shoot on one clock and plan at their
      // shots), a late one not yet, and counting a fused one again would
      // take its ground as seen twice (FusedShots: a camera stamps a shot
      // within half a period of when it was due).
      const double half_period_s = 0.5 / member.kit.camera.rate_hz;
      for (std::size_t i = 0; i < line->size() && config_.count_teammate_shots && !removed; ++i) {
        const double until = i + 1 < line->size() ? (*line)[i + 1].team.start_mission_s
                                                  : std::numeric_limits<double>::infinity();
        for (const MeasurementPose& shot : (*line)[i].measurement_poses) {
          if (shot.mission_time_s >= now_s && shot.mission_time_s < until &&
              !fused.Fused(member.uav_id, shot.mission_time_s, half_period_s)) {
            mate.pending_shots_W.push_back(shot.position_W);
          }
        }
      }
    }
    last_report_s = std::max(last_report_s, fused.Latest(member.uav_id));
    // Removed in the air, or silent: it may drift from where it should be
    // hovering, at its max speed (docs/teams.md "Silent and removed UAVs").
    if (removed || newest_s - last_report_s > config_.silent_after_s) {
      const double hovering_from_s = line != nullptr
                                         ? mate.start_mission_s + mate.trajectory.Duration()
                                         : member.start.mission_time_s;
      mate.drift_from_s = std::max(last_report_s, hovering_from_s);
      mate.drift_m_s = member.kit.limits.dynamics.max_speed_m_s;
    }
    mates.push_back(std::move(mate));
    versions->emplace_back(member.uav_id, version);
  }
  std::sort(versions->begin(), versions->end());
  return mates;
}

}  // namespace oaipp::server
