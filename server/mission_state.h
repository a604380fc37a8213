// What a snapshot of a mission holds (server/store/state_codec.h) and what
// Mission::Restore starts from. A header of its own, so that the store's
// codec does not depend on the mission's code.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "Eigen/Core"
#include "core/environment/obstacle.h"
#include "server/idempotency_memo.h"

namespace oaipp::server {

// Everything a mission holds after the record `sequence` of its log, but its
// config: what a snapshot stores, and what Mission::Restore starts from.
struct MissionState {
  std::int64_t sequence = 0;
  std::vector<Obstacle> obstacles = {};
  std::vector<int> covered_cells = {};  // fused as near-certain zeros
  // A dense map: its mean and covariance.
  Eigen::VectorXd mean = {};
  Eigen::MatrixXd covariance = {};
  // A sparse map instead: what was fused into it, per cell
  // (SparseGpMap::Additions).
  Eigen::VectorXd added_precision = {};
  Eigen::VectorXd added_information = {};
  // A sparse map's trace as last computed, with the measurements it
  // includes; nullopt: not known (the restore computes it).
  std::optional<double> trace = std::nullopt;
  std::int64_t trace_measurements_fused = 0;
  std::int64_t measurements_fused = 0;
  double mission_time_s = 0.0;
  std::int64_t paths_planned = 0;
  std::string planner_state = {};  // Planner::SaveState
  // request_id -> fingerprint and first answer, oldest first.
  std::vector<std::pair<std::string, RememberedAnswer>> answers = {};
  // A team's committed trajectories (PlannedPath::team set), one per UAV
  // that has planned, in uav_id order.
  std::vector<PlannedPath> committed = {};
  // Members taken out of the team (RemoveTeamMember), in the order removed.
  std::vector<std::string> removed_uav_ids = {};
  std::vector<std::string> landed_uav_ids = {};  // of those, the ones that landed
  // The mission time of the latest measurement fused from each UAV.
  std::map<std::string, double> last_shot_s = {};
  // When each UAV's fused shots still of use were taken (FusedShots); a
  // snapshot that has none for a UAV gives its last_shot_s instead.
  std::map<std::string, std::vector<double>> fused_shot_s = {};
};

}  // namespace oaipp::server
