#include "server/mission_planning.h"

#include <algorithm>
#include <limits>

#include "api/status.h"
#include "core/common/status_macros.h"
#include "core/planning/planners.h"

namespace oaipp::server {
namespace {

// A UAV that has not planned yet, held at its start: a one-point trajectory.
PolynomialTrajectory HeldAt(const UavState& start) {
  PolynomialTrajectory::SegmentCoefficients c = PolynomialTrajectory::SegmentCoefficients::Zero();
  c.row(0) = start.position_W.transpose();
  return *PolynomialTrajectory::FromCoefficients({1.0}, {c});
}

}  // namespace

MissionPlanning::MissionPlanning(const api::MissionConfig& config, std::unique_ptr<Planner> planner)
    : config_(config), planner_(std::move(planner)) {}

MissionPlanning::Held::Held(MissionPlanning& planning)
    : planning_(planning), lock_(&planning.mu_) {}

MissionPlanning::Held::~Held() = default;

// Each accessor tells the analysis what a Held's life guarantees: the lock
// is held.
Planner& MissionPlanning::Held::planner() const {
  planning_.mu_.AssertHeld();
  return *planning_.planner_;
}

absl::StatusOr<Planner*> MissionPlanning::Held::PlannerOf(const std::string& uav_id) const {
  planning_.mu_.AssertHeld();
  if (planning_.config_.team.empty()) return planning_.planner_.get();
  // A team's kinds (OA-IPP, random) keep no state between plans, so each
  // member's planner, made with its own limits when first asked, plans as
  // the mission's would with those limits.
  std::unique_ptr<Planner>& own = planning_.member_planners_[uav_id];
  if (own == nullptr) {
    OAIPP_ASSIGN_OR_RETURN(own, MakePlanner(planning_.config_.PlannerFor(uav_id)));
  }
  return own.get();
}

void MissionPlanning::Held::ErasePlanner(const std::string& uav_id) const {
  planning_.mu_.AssertHeld();
  planning_.member_planners_.erase(uav_id);
}

TeamTimelines& MissionPlanning::Held::timelines() const {
  planning_.mu_.AssertHeld();
  return planning_.timelines_;
}

absl::Status MissionPlanning::NamedForMember(const absl::Status& status,
                                             const std::string& uav_id) const {
  for (std::size_t i = 0; i < config_.team.size(); ++i) {
    // A member's limits are its own (spec.team[i].flight): a plan's error
    // names that field, not the mission's.
    if (config_.team[i].uav_id == uav_id) {
      return api::WithApiFieldNames(status, static_cast<int>(i));
    }
  }
  return status;
}

std::vector<Teammate> MissionPlanning::Held::TeammatesOf(
    const std::string& uav_id, double now_s, double newest_s, const FusedShots& fused,
    const TeamRoster& roster, std::vector<std::pair<std::string, std::int64_t>>* versions) const {
  planning_.mu_.AssertHeld();
  const api::MissionConfig& config = planning_.config_;
  std::vector<Teammate> mates;
  for (const api::TeamMember& member : config.team) {
    if (member.uav_id == uav_id || roster.Landed(member.uav_id)) continue;
    const bool removed = roster.Removed(member.uav_id);
    const std::vector<PlannedPath>* line = planning_.timelines_.Of(member.uav_id);
    Teammate mate{.uav_id = member.uav_id,
                  .trajectory = line != nullptr ? line->back().trajectory : HeldAt(member.start),
                  .start_mission_s = line != nullptr ? line->back().team.start_mission_s
                                                     : member.start.mission_time_s,
                  .min_distance_m = config.PairDistance(uav_id, member.uav_id),
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
      for (std::size_t i = 0; i < line->size() && config.count_teammate_shots && !removed; ++i) {
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
    if (removed || newest_s - last_report_s > config.silent_after_s) {
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
