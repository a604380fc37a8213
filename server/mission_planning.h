// A mission's planning state: its planner (which keeps state: lawnmower
// pattern), a team's planners, each with its member's limits, the team's
// committed plans (TeamTimelines) and the conditioning chain its plans
// share. One lock guards it, held for a whole plan: plans of one mission
// run one at a time. It is the outermost of the mission's locks (mission.h
// gives their order); Held holds it and is the way to what it guards.
//
//   MissionPlanning::Held planning(planning_);
//   OAIPP_ASSIGN_OR_RETURN(Planner * planner, planning.PlannerOf("b"));
//   planning.timelines().Commit(path, newest_s);
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "api/mission_config.h"
#include "core/planning/conditioning_chain.h"
#include "core/planning/planner.h"
#include "server/fused_shots.h"
#include "server/team_roster.h"
#include "server/team_timelines.h"

namespace oaipp::server {

class MissionPlanning {
 public:
  // `config` is the mission's and outlives this; `planner` is the
  // mission's (a team's members get their own, PlannerOf).
  MissionPlanning(const api::MissionConfig& config, std::unique_ptr<Planner> planner);
  MissionPlanning(const MissionPlanning&) = delete;
  MissionPlanning& operator=(const MissionPlanning&) = delete;

  // Holds the lock for as long as it lives.
  class ABSL_SCOPED_LOCKABLE Held {
   public:
    explicit Held(MissionPlanning& planning) ABSL_EXCLUSIVE_LOCK_FUNCTION(planning.mu_);
    ~Held() ABSL_UNLOCK_FUNCTION();
    Held(const Held&) = delete;
    Held& operator=(const Held&) = delete;

    // The mission's planner (its state is what a snapshot keeps).
    [[nodiscard]] Planner& planner() const;
    // The planner that plans for `uav_id`: the mission's for one UAV, a
    // member's own (its limits) for a team.
    [[nodiscard]] absl::StatusOr<Planner*> PlannerOf(const std::string& uav_id) const;
    // Forgets the own planner of `uav_id` (taken out of the team).
    void ErasePlanner(const std::string& uav_id) const;
    // A team's committed plans, a timeline per UAV.
    [[nodiscard]] TeamTimelines& timelines() const;
    // The chain a team's plans condition the map on (chain_).
    [[nodiscard]] ConditioningChain& chain() const { return planning_.chain_; }
    // A team's other UAVs in the air as the plan for `uav_id` at mission
    // time `now_s` must keep clear of them (docs/teams.md "The guarantee"):
    // each one's timeline (or, before its first plan, its start, held) and
    // the distance the pair keeps (PairDistance); one removed in the air
    // (`roster`), or silent for more than silent_after_s before `newest_s`,
    // may drift at its max speed from when it should be hovering. With
    // them, the shots still to come of those flying: at or after now_s, on
    // the plan in force when taken, and not yet in the plan's map (`fused`,
    // FusedShots's rule). Also their plan versions (0: none yet), in uav_id
    // order.
    [[nodiscard]] std::vector<Teammate> TeammatesOf(
        const std::string& uav_id, double now_s, double newest_s, const FusedShots& fused,
        const TeamRoster& roster,
        std::vector<std::pair<std::string, std::int64_t>>* versions) const;

   private:
    MissionPlanning& planning_;
    absl::MutexLock lock_;
  };

  // `status` (a plan's error for team member `uav_id`) naming the member's
  // own limits, from the fields it carries as data (api::WithApiFieldNames).
  // Reads the config alone: no lock.
  [[nodiscard]] absl::Status NamedForMember(const absl::Status& status,
                                            const std::string& uav_id) const;
  // Memory held by the chain, read without the lock (a plan holds that for
  // its whole length): the chain has its own.
  [[nodiscard]] std::int64_t chain_bytes() const { return chain_.bytes(); }

 private:
  const api::MissionConfig& config_;
  // Guards the planners and the timelines; held for a whole plan (Held).
  absl::Mutex mu_;
  std::unique_ptr<Planner> planner_ ABSL_GUARDED_BY(mu_);
  // A team's planners, made when first asked for (PlannerOf).
  std::map<std::string, std::unique_ptr<Planner>> member_planners_ ABSL_GUARDED_BY(mu_);
  TeamTimelines timelines_ ABSL_GUARDED_BY(mu_);
  // A team's plans condition the map (or a large field's window) on each
  // other's pending shots from the last plan's conditioning when it was
  // made from the same covariance (MissionMap::ForPlan::key; docs/method.md §7.8).
  // Used under mu_, but not guarded by it: it has its own lock, so that
  // chain_bytes() waits for no plan.
  ConditioningChain chain_;
};

}  // namespace oaipp::server
