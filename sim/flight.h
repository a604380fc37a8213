// The simulated UAV flying returned trajectories: where it is every 20 ms of
// flight, how far it has flown, how often it came closer to an obstacle
// than r_uav / 2 under the exact geometry (the check every returned path
// must pass), and a thinned trace of the flight for pictures.
//
//   Flight flight(simulation, start_W);
//   OAIPP_ASSIGN_OR_RETURN(double stopped_s, flight.Fly(trajectory, fly_s,
//       [&](double t_s) -> absl::StatusOr<bool> {
//         return TakeShotsDueBy(t_s);   // called after each step; false: stop here
//       }));
//   int collisions = flight.collisions();
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/trajectory/polynomial_trajectory.h"
#include "sim/simulation.h"

namespace oaipp::sim {

class Flight {
 public:
  // Steps of flight time: <= 0.1 m at 5 m/s.
  static constexpr double kStep_s = 0.02;
  // The trace keeps a point once the UAV is this far from the last one kept.
  static constexpr double kTraceSpacing_m = 0.5;

  // `simulation` must outlive the flight; `uav_id` names the team member
  // flown (its radius; "": the mission's UAV).
  Flight(const Simulation& simulation, const Vec3& start_W, const std::string& uav_id = "");

  // Flies `trajectory` from t = 0 to until_s (clamped to its duration) in
  // steps of kStep_s, the last one ending at until_s exactly, calling
  // `after_step(t_s)` after each, which returns whether to fly on. Returns
  // the time reached: until_s clamped, or the step whose callback returned
  // false; or the callback's first error, which also stops the flight.
  [[nodiscard]] absl::StatusOr<double> Fly(
      const PolynomialTrajectory& trajectory, double until_s,
      const std::function<absl::StatusOr<bool>(double t_s)>& after_step);

  // One step by hand, for flights that interleave several UAVs' steps: the
  // UAV moves to p_W, which counts as Fly's steps do.
  void MoveTo(const Vec3& p_W);

  [[nodiscard]] double path_length_m() const { return path_length_m_; }
  [[nodiscard]] int collisions() const { return collisions_; }
  [[nodiscard]] const std::vector<Vec3>& trace_W() const { return trace_W_; }

 private:
  const Simulation* simulation_;
  double uav_radius_m_;
  Vec3 position_W_;
  double path_length_m_ = 0.0;
  int collisions_ = 0;
  std::vector<Vec3> trace_W_;
};

}  // namespace oaipp::sim
