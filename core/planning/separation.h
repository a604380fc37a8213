// Keeping the UAVs of one mission apart (docs/method.md §7.8, docs/teams.md).
//
// One distance rule serves the optimiser and the final check alike: two
// UAVs are separated at an instant when their centres are at least the
// pair's distance apart (RequiredDistance: min_separation_m or the pair's
// own min_distance_m, whichever is more, plus a silent teammate's drift).
// A teammate is where its timeline puts it (Teammate, planner.h: each
// committed plan flown from its start until the next one starts, then
// hovering at the last point). The optimiser counts, at the collision
// cost's samples, the instants at which the candidate is not separated from
// some teammate (SeparationSamples: each costs what a colliding sample
// costs). The final check proves separation at every instant, not just at
// samples (CheckSeparationExact): the slack (distance minus required
// distance) changes no faster than the sum of the two speeds plus the drift
// rate v, so samples dt apart, each with a slack of at least v dt / 2, leave
// no instant between them short of the required distance.
//
//   int bad = SeparationSamples(path, now_s, teammates, 4.0, 20.0);
//   SeparationSampler sampler(now_s, teammates, 4.0, 20.0);   // the same, for many paths
//   int bad = sampler.Samples(path);
//   OAIPP_RETURN_IF_ERROR(CheckSeparationExact(path, now_s, teammates, 4.0));
#pragma once

#include <algorithm>
#include <iterator>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "core/common/geometry.h"
#include "core/planning/planner.h"

namespace oaipp {

// The rule itself: a_W and b_W at least distance_m apart.
[[nodiscard]] inline bool Separated(const Vec3& a_W, const Vec3& b_W, double distance_m) {
  return (a_W - b_W).squaredNorm() >= distance_m * distance_m;
}

// Where `teammate` is at mission time t: on the timeline piece in force at
// t, at the first piece's first point before the timeline starts, hovering
// at its last point after the newest piece ends.
[[nodiscard]] inline Vec3 TeammatePosition(const Teammate& teammate, double mission_time_s) {
  if (mission_time_s >= teammate.start_mission_s || teammate.earlier.empty()) {
    return teammate.trajectory.Position(mission_time_s - teammate.start_mission_s);
  }
  const auto after = std::upper_bound(
      teammate.earlier.begin(), teammate.earlier.end(), mission_time_s,
      [](double t, const TimelinePiece& piece) { return t < piece.start_mission_s; });
  const TimelinePiece& piece = after == teammate.earlier.begin() ? *after : *std::prev(after);
  return piece.trajectory.Position(mission_time_s - piece.start_mission_s);
}

// How far apart the planning UAV and `teammate` must be at mission time t.
[[nodiscard]] inline double RequiredDistance(const Teammate& teammate, double mission_time_s,
                                             double min_separation_m) {
  const double drifted = mission_time_s > teammate.drift_from_s
                             ? teammate.drift_m_s * (mission_time_s - teammate.drift_from_s)
                             : 0.0;
  return std::max(min_separation_m, teammate.min_distance_m) + drifted;
}

// The fastest `teammate` flies on any piece of its timeline, m/s.
[[nodiscard]] double TimelineMaxSpeed(const Teammate& teammate);

// The last instant (mission time) that a check of a trajectory starting at
// start_mission_s against `teammates` must reach: when the last of them, or
// the trajectory itself, comes to rest for good.
[[nodiscard]] double SeparationHorizon(const PolynomialTrajectory& trajectory,
                                       double start_mission_s, std::span<const Teammate> teammates);

// How many samples, every 1 / rate_hz from the trajectory's start to
// SeparationHorizon, find the UAV (on `trajectory` from start_mission_s,
// then hovering at its end) closer to some teammate than RequiredDistance.
[[nodiscard]] int SeparationSamples(const PolynomialTrajectory& trajectory, double start_mission_s,
                                    std::span<const Teammate> teammates, double min_separation_m,
                                    double rate_hz);

// SeparationSamples for the many candidates of one plan: the same start,
// teammates and rate, so the teammates' positions at the sample instants
// are computed once, here (SeparationSamples builds one for a single
// trajectory). The teammates must outlive the sampler.
class SeparationSampler {
 public:
  SeparationSampler(double start_mission_s, std::span<const Teammate> teammates,
                    double min_separation_m, double rate_hz);

  [[nodiscard]] int Samples(const PolynomialTrajectory& trajectory) const;

 private:
  double start_mission_s_;
  std::span<const Teammate> teammates_;
  double min_separation_m_;
  double rate_hz_;
  // Teammate m at sample i (start_mission_s + i / rate_hz): positions_[i *
  // teammates.size() + m], for i < grid_. Past the grid every teammate is at
  // rest at its last point (end_[m]).
  int grid_ = 0;
  double dt_ = 0.0;
  std::vector<Vec3> positions_;
  std::vector<Vec3> end_;
};

// OK when the UAV keeps RequiredDistance from every teammate at every
// instant from start_mission_s to SeparationHorizon (see above: samples at
// most spacing_m / v apart with the margin v dt / 2); FailedPrecondition
// naming the teammate's uav_id, the mission time and the distance otherwise.
[[nodiscard]] absl::Status CheckSeparationExact(const PolynomialTrajectory& trajectory,
                                                double start_mission_s,
                                                std::span<const Teammate> teammates,
                                                double min_separation_m, double spacing_m = 0.1);

}  // namespace oaipp
