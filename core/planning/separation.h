// Keeping the UAVs of one mission apart (docs/method.md §7.8).
//
// One distance rule serves the optimiser and the final check alike: two
// UAVs are separated at an instant when their centres are at least
// min_separation_m apart (Separated). A UAV that reaches the end of its
// trajectory hovers at its last point until it gets a new one; a teammate
// is where its committed trajectory puts it (Teammate, planner.h). The
// optimiser counts, at the collision cost's samples, the instants at which
// the candidate is not separated from some teammate (SeparationSamples: each
// costs what a colliding sample costs). The final check proves separation
// at every instant, not just at samples (CheckSeparationExact): the distance
// between two UAVs changes no faster than the sum of their speeds v, so
// samples dt apart, each at least min_separation_m + v dt / 2 apart, leave
// no instant between them closer than min_separation_m.
//
//   int bad = SeparationSamples(path, now_s, teammates, 4.0, 20.0);
//   SeparationSampler sampler(now_s, teammates, 4.0, 20.0);   // the same, for many paths
//   int bad = sampler.Samples(path);
//   OAIPP_RETURN_IF_ERROR(CheckSeparationExact(path, now_s, teammates, 4.0));
#pragma once

#include <span>
#include <vector>

#include "absl/status/status.h"
#include "core/common/geometry.h"
#include "core/planning/planner.h"

namespace oaipp {

// The rule itself.
[[nodiscard]] inline bool Separated(const Vec3& a_W, const Vec3& b_W, double min_separation_m) {
  return (a_W - b_W).squaredNorm() >= min_separation_m * min_separation_m;
}

// Where `teammate` is at mission time t: on its trajectory, at its first
// point before it starts, hovering at its last after it ends.
[[nodiscard]] inline Vec3 TeammatePosition(const Teammate& teammate, double mission_time_s) {
  return teammate.trajectory.Position(mission_time_s - teammate.start_mission_s);
}

// The last instant (mission time) that a check of a trajectory starting at
// start_mission_s against `teammates` must reach: when the last of them, or
// the trajectory itself, comes to rest for good.
[[nodiscard]] double SeparationHorizon(const PolynomialTrajectory& trajectory,
                                       double start_mission_s, std::span<const Teammate> teammates);

// How many samples, every 1 / rate_hz from the trajectory's start to
// SeparationHorizon, find the UAV (on `trajectory` from start_mission_s,
// then hovering at its end) not Separated from some teammate.
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
  std::vector<Vec3> positions_;
  std::vector<Vec3> end_;
};

// OK when the UAV stays Separated from every teammate at every instant from
// start_mission_s to SeparationHorizon (see above: samples at most
// spacing_m / v apart with the margin v dt / 2); FailedPrecondition naming
// the teammate's uav_id, the mission time and the distance otherwise.
[[nodiscard]] absl::Status CheckSeparationExact(const PolynomialTrajectory& trajectory,
                                                double start_mission_s,
                                                std::span<const Teammate> teammates,
                                                double min_separation_m, double spacing_m = 0.1);

}  // namespace oaipp
