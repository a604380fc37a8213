// A mission's flight as the live view shows it: where each UAV reported
// being, what it last planned and which cells the UAVs saw.
//
//   FlightTrack track;
//   track.Add(uav_id, camera_position_W, detected_cells, /*planned_W=*/nullptr);
//   const MissionTrack copy = track.Copy();
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "absl/synchronization/mutex.h"
#include "core/common/geometry.h"

namespace oaipp::server {

// What the live view draws besides the map (server/web_view.h): kept in
// memory only, bounded, and rebuilt from what a restart replays.
struct MissionTrack {
  static constexpr std::size_t kMaxFlown = 4096;
  static constexpr std::size_t kMaxDetected = 4096;
  // One UAV's: uav_id "" without a team.
  struct Uav {
    // Where the UAV reported being (camera positions and plan starts), in
    // arrival order; the oldest are dropped past kMaxFlown.
    std::vector<Vec3> flown_W;
    // Its last planned trajectory, sampled at 10 Hz.
    std::vector<Vec3> planned_W;
  };
  // Every UAV that has reported, by uav_id (at most the team's 16).
  std::map<std::string, Uav> uavs;
  // Cells some measurement saw (label >= kDetectedLabel), sorted.
  std::vector<int> detected_cells;
};

// One mission's track behind a leaf lock of its own: the live view reads it
// without waiting for a change of the mission in progress.
class FlightTrack {
 public:
  // Adds a position UAV `uav_id` reported, the cells detected there
  // (`detected` sorted) and, unless nullptr, the trajectory just planned
  // from it.
  void Add(const std::string& uav_id, const Vec3& p_W, const std::vector<int>& detected,
           const std::vector<Vec3>* planned_W);
  // The track as it is now (a copy).
  [[nodiscard]] MissionTrack Copy() const;

 private:
  mutable absl::Mutex mu_;
  MissionTrack track_ ABSL_GUARDED_BY(mu_);
};

}  // namespace oaipp::server
