#include "sim/flight.h"

#include <algorithm>

#include "core/common/status_macros.h"

namespace oaipp::sim {

Flight::Flight(const Simulation& simulation, const Vec3& start_W, const std::string& uav_id)
    : simulation_(&simulation),
      uav_radius_m_(simulation.config().KitOf(uav_id).limits.uav_radius_m),
      position_W_(start_W),
      trace_W_{start_W} {}

void Flight::MoveTo(const Vec3& p_W) {
  path_length_m_ += (p_W - position_W_).norm();
  position_W_ = p_W;
  if (simulation_->Collides(p_W, uav_radius_m_)) ++collisions_;
  if ((p_W - trace_W_.back()).norm() > kTraceSpacing_m) trace_W_.push_back(p_W);
}

absl::StatusOr<double> Flight::Fly(
    const PolynomialTrajectory& trajectory, double until_s,
    const std::function<absl::StatusOr<bool>(double t_s)>& after_step) {
  const double end_s = std::clamp(until_s, 0.0, trajectory.Duration());
  for (double t = 0.0;; t = std::min(t + kStep_s, end_s)) {
    MoveTo(trajectory.Position(t));
    OAIPP_ASSIGN_OR_RETURN(const bool fly_on, after_step(t));
    if (!fly_on || t >= end_s) return t;
  }
}

}  // namespace oaipp::sim
