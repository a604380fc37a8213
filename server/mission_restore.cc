// How a mission comes back after a restart or a takeover: from a snapshot
// (Restore) or by applying its log again (Replay), and the plans of its log
// taken back in order (RestorePlan).
#include "server/mission.h"

#include <algorithm>
#include <utility>
#include <variant>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"
#include "core/planning/planners.h"
#include "server/site_caches.h"

namespace oaipp::server {

absl::StatusOr<std::shared_ptr<Mission>> Mission::Restore(std::string id, MissionConfig config,
                                                          MissionState state,
                                                          const SiteCaches& caches) {
  // The world as the snapshot saw it: the spec's field and flight settings
  // with the state's obstacles, built as a new mission's world is (a
  // takeover by a replica that holds missions over the same world clones
  // theirs instead of computing the ESDF again).
  MissionConfig stored_world = config;
  stored_world.obstacles = state.obstacles;
  OAIPP_ASSIGN_OR_RETURN(
      Environment env,
      BuildWorld(stored_world, caches.worlds != nullptr ? WorldKey(stored_world) : "", caches));
  OAIPP_ASSIGN_OR_RETURN(FieldGrid grid, config.MakeGrid());
  const bool sparse = config.ResolveMapBackend() == api::MapBackend::kSparse;
  const Eigen::Index n = grid.num_cells();
  const bool fits = sparse ? state.added_precision.size() == n &&
                                 state.added_information.size() == n && state.mean.size() == 0
                           : state.mean.size() == n && state.covariance.rows() == n &&
                                 state.covariance.cols() == n && state.added_precision.size() == 0;
  if (!fits) {
    return absl::InvalidArgumentError(
        absl::StrCat("state: the snapshot's map (", state.mean.size(), " means, ",
                     state.added_precision.size(), " sparse additions) does not fit the spec's ",
                     sparse ? "sparse" : "dense", " map of ", n, " cells"));
  }
  if (sparse) {
    OAIPP_RETURN_IF_ERROR(
        SparseGpMap::CheckAdditions(state.added_precision, state.added_information));
  }
  for (int cell : state.covered_cells) {
    if (!grid.IsValidCell(cell)) {
      return absl::InvalidArgumentError(
          absl::StrCat("state: covered cell ", cell, " is outside the field"));
    }
  }
  for (const std::string& uav_id : state.removed_uav_ids) {
    if (config.FindMember(uav_id) == nullptr) {
      return absl::InvalidArgumentError(
          absl::StrCat("state: a removed UAV '", uav_id, "', which is not in the team"));
    }
  }
  for (const std::string& uav_id : state.landed_uav_ids) {
    if (std::find(state.removed_uav_ids.begin(), state.removed_uav_ids.end(), uav_id) ==
        state.removed_uav_ids.end()) {
      return absl::InvalidArgumentError(
          absl::StrCat("state: a landed UAV '", uav_id, "', which was not removed"));
    }
  }
  for (const auto& [uav_id, time_s] : state.last_shot_s) {
    if (!uav_id.empty() && config.FindMember(uav_id) == nullptr) {
      return absl::InvalidArgumentError(absl::StrCat("state: a measurement time of UAV '", uav_id,
                                                     "', which is not in the team"));
    }
  }
  for (const auto& [uav_id, times] : state.fused_shot_s) {
    if (!uav_id.empty() && config.FindMember(uav_id) == nullptr) {
      return absl::InvalidArgumentError(
          absl::StrCat("state: shot times of UAV '", uav_id, "', which is not in the team"));
    }
  }
  for (const PlannedPath& path : state.committed) {
    if (config.FindMember(path.team.uav_id) == nullptr) {
      return absl::InvalidArgumentError(absl::StrCat("state: a committed trajectory of UAV '",
                                                     path.team.uav_id,
                                                     "', which is not in the team"));
    }
  }
  OAIPP_ASSIGN_OR_RETURN(std::unique_ptr<Planner> planner, MakePlanner(config.planner));
  OAIPP_RETURN_IF_ERROR(planner->RestoreState(state.planner_state));
  std::shared_ptr<Mission> mission;
  if (sparse) {
    OAIPP_ASSIGN_OR_RETURN(
        std::unique_ptr<LargeFieldMap> large,
        LargeFieldMap::Create(grid, config.gp, caches.gmrf_priors, config.prior_map.get()));
    mission.reset(new Mission(std::move(id), std::move(config), std::move(grid), std::move(env),
                              nullptr, std::move(large), std::move(planner), caches));
  } else {
    OAIPP_ASSIGN_OR_RETURN(
        GpMap map, GpMap::FromPrior(grid, std::move(state.mean), std::move(state.covariance)));
    map.set_dense_backend(config.planner.common.information.dense_backend);
    mission.reset(new Mission(std::move(id), std::move(config), std::move(grid), std::move(env),
                              std::make_shared<GpMap>(std::move(map)), nullptr, std::move(planner),
                              caches));
  }
  LargeFieldMap::Target restored;
  {
    absl::MutexLock lock(&mission->mu_);
    mission->measurements_fused_ = state.measurements_fused;
    mission->mission_time_s_ = state.mission_time_s;
    mission->fused_shots_.Restore(std::move(state.fused_shot_s), state.last_shot_s);
    SparseGpMap::Additions additions{.precision = std::move(state.added_precision),
                                     .information = std::move(state.added_information)};
    mission->map_.Restore(state.covered_cells, sparse ? &additions : nullptr);
    if (sparse) restored = mission->map_.SparseTarget(mission->measurements_fused_);
  }
  if (sparse && state.trace.has_value()) {
    // The snapshot's trace until the next variance map (SettleMap): a
    // takeover need not wait seconds for one.
    mission->summary_.RestoreTrace(*state.trace, state.trace_measurements_fused);
  } else if (sparse) {
    // Else the variance map of the state, for the trace the mission reports.
    OAIPP_RETURN_IF_ERROR(mission->map_.large()->Read(restored).status());
  }
  {
    absl::MutexLock lock(&mission->mu_);
    mission->Publish();
  }
  mission->log_.ContinueAfter(state.sequence);
  mission->answers_.Restore(std::move(state.answers));
  mission->paths_planned_ = state.paths_planned;
  {
    MissionPlanning::Held planning(mission->planning_);
    for (const PlannedPath& path : state.committed) {
      planning.timelines().Commit(path, state.mission_time_s);
    }
    mission->roster_.Restore(std::move(state.removed_uav_ids), std::move(state.landed_uav_ids));
  }
  mission->snapshots_.StoredAt(state.sequence, state.measurements_fused);
  return mission;
}

absl::StatusOr<std::shared_ptr<Mission>> Mission::Replay(std::string id, MissionConfig config,
                                                         const std::vector<LogEntry>& log) {
  OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission,
                         Create(std::move(id), std::move(config)));
  for (const LogEntry& entry : log) {
    if (const auto* change = std::get_if<ObstacleChange>(&entry)) {
      OAIPP_RETURN_IF_ERROR(mission->UpdateObstacles(*change, "").status());
    } else {
      OAIPP_RETURN_IF_ERROR(
          mission->AddMeasurement(std::get<MeasurementInput>(entry), "").status());
    }
  }
  return mission;
}

absl::Status Mission::RestorePlan(const RequestKey& request, PlannedPath path,
                                  const std::string& planner_state) {
  MissionPlanning::Held planning(planning_);
  OAIPP_RETURN_IF_ERROR(planning.planner().RestoreState(planner_state));
  if (!path.team.uav_id.empty() && config_.FindMember(path.team.uav_id) == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat("a plan of UAV '", path.team.uav_id, "', which is not in the team"));
  }
  OAIPP_RETURN_IF_ERROR(PersistPlan(nullptr, path, planner_state));
  ++paths_planned_;
  if (!path.team.uav_id.empty()) {
    double newest_s;
    {
      absl::ReaderMutexLock lock(&mu_);
      newest_s = mission_time_s_;
    }
    planning.timelines().Commit(path, std::max(newest_s, path.team.start_mission_s));
  }
  answers_.Remember(request, std::move(path));
  return absl::OkStatus();
}

}  // namespace oaipp::server
