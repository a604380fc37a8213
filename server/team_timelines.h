// Each team member's future as the server holds it (docs/teams.md "The
// guarantee"): its committed plans as a timeline, each flown from its start
// on the mission clock until the next one starts. A teammate's plan is
// checked against every other UAV's timeline, so a plan that arrives late
// (stamped before a teammate's newer plan) is checked against what that
// teammate was really flying then, and a plan made ahead (stamped where its
// UAV will be) leaves the UAV's current plan in force until it starts.
//
//   TeamTimelines timelines;
//   OAIPP_RETURN_IF_ERROR(timelines.CheckStart("a", 12.0, /*newest_s=*/13.5));
//   timelines.Commit(path, /*newest_s=*/13.5);   // path.team.uav_id == "a"
//   const std::vector<PlannedPath>* a = timelines.Of("a");
//
// Not thread-safe: the mission holds it under its planner lock.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "core/planning/planner.h"

namespace oaipp::server {

class TeamTimelines {
 public:
  // How far behind the newest mission time the mission has seen a plan may
  // start, seconds. Older starts are refused, and plans superseded before
  // that time are let go.
  static constexpr double kMaxLag_s = 30.0;

  // OK when `uav_id` may commit a plan from start_s: not before the start
  // of a plan the server already holds for it, and not more than kMaxLag_s
  // behind newest_s. Else FailedPrecondition naming state.mission_time_s.
  [[nodiscard]] absl::Status CheckStart(const std::string& uav_id, double start_s,
                                        double newest_s) const;
  // Adds `path` (path.team.uav_id and start_mission_s set) to its UAV's
  // timeline: in force from its start, replacing a plan of the same start;
  // then lets go of plans that ended (were superseded) more than kMaxLag_s
  // before newest_s.
  void Commit(const PlannedPath& path, double newest_s);
  // `uav_id`'s timeline, by start; nullptr before its first plan.
  [[nodiscard]] const std::vector<PlannedPath>* Of(const std::string& uav_id) const;
  // Forgets `uav_id` (it landed).
  void Erase(const std::string& uav_id) { timelines_.erase(uav_id); }
  // Every plan held, by uav_id then start (what a snapshot keeps).
  [[nodiscard]] std::vector<PlannedPath> All() const;

 private:
  std::map<std::string, std::vector<PlannedPath>> timelines_;
};

}  // namespace oaipp::server
