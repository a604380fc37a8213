// How a mission comes back after a restart or a takeover: from a snapshot
// (Restore) or by applying its log again (Replay), and the plans of its log
// taken back in order (RestorePlan).
#include "server/mission.h"

#include <utility>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"
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
  if (state.mean.size() != grid.num_cells() || state.covariance.rows() != grid.num_cells() ||
      state.covariance.cols() != grid.num_cells()) {
    return absl::InvalidArgumentError(absl::StrCat("state: a map of ", state.mean.size(),
                                                   " cells does not fit the ", grid.num_cells(),
                                                   "-cell field of the spec"));
  }
  for (int cell : state.covered_cells) {
    if (!grid.IsValidCell(cell)) {
      return absl::InvalidArgumentError(
          absl::StrCat("state: covered cell ", cell, " is outside the field"));
    }
  }
  OAIPP_ASSIGN_OR_RETURN(
      GpMap map, GpMap::FromPrior(grid, std::move(state.mean), std::move(state.covariance)));
  map.set_dense_backend(config.planner.common.information.dense_backend);
  OAIPP_ASSIGN_OR_RETURN(std::unique_ptr<Planner> planner, MakePlanner(config.planner));
  OAIPP_RETURN_IF_ERROR(planner->RestoreState(state.planner_state));
  std::shared_ptr<Mission> mission(new Mission(std::move(id), std::move(config), std::move(env),
                                               std::make_shared<GpMap>(std::move(map)),
                                               std::move(planner), caches));
  {
    absl::MutexLock lock(&mission->mu_);
    mission->covered_cells_.insert(state.covered_cells.begin(), state.covered_cells.end());
    mission->measurements_fused_ = state.measurements_fused;
    mission->mission_time_s_ = state.mission_time_s;
    mission->Publish();
  }
  {
    absl::MutexLock lock(&mission->sequence_mu_);
    mission->next_sequence_ = state.sequence + 1;
  }
  mission->answers_.Restore(std::move(state.answers));
  mission->paths_planned_ = state.paths_planned;
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
  absl::MutexLock planner_lock(&planner_mu_);
  OAIPP_RETURN_IF_ERROR(planner_->RestoreState(planner_state));
  OAIPP_RETURN_IF_ERROR(PersistPlan(nullptr, path, planner_state));
  ++paths_planned_;
  answers_.Remember(request, std::move(path));
  return absl::OkStatus();
}

}  // namespace oaipp::server
