#include "core/planning/separation.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace oaipp {

double TimelineMaxSpeed(const Teammate& teammate) {
  double fastest = teammate.trajectory.MaxSpeed();
  for (const TimelinePiece& piece : teammate.earlier) {
    fastest = std::max(fastest, piece.trajectory.MaxSpeed());
  }
  return fastest;
}

double SeparationHorizon(const PolynomialTrajectory& trajectory, double start_mission_s,
                         std::span<const Teammate> teammates) {
  double end = start_mission_s + trajectory.Duration();
  for (const Teammate& t : teammates) {
    end = std::max(end, t.start_mission_s + t.trajectory.Duration());
  }
  return end;
}

SeparationSampler::SeparationSampler(double start_mission_s, std::span<const Teammate> teammates,
                                     double min_separation_m, double rate_hz)
    : start_mission_s_(start_mission_s),
      teammates_(teammates),
      min_separation_m_(min_separation_m),
      rate_hz_(rate_hz) {
  double last_end = start_mission_s;
  for (const Teammate& mate : teammates) {
    last_end = std::max(last_end, mate.start_mission_s + mate.trajectory.Duration());
    end_.push_back(mate.trajectory.Position(mate.trajectory.Duration()));
  }
  // Two samples past the last end: a teammate's trajectory clamps its time
  // to its duration, so from there on each one is exactly at end_.
  const double dt = 1.0 / rate_hz;
  dt_ = dt;
  grid_ = static_cast<int>(std::floor((last_end - start_mission_s) / dt)) + 3;
  positions_.reserve(static_cast<std::size_t>(grid_) * teammates.size());
  for (int i = 0; i < grid_; ++i) {
    for (const Teammate& mate : teammates) {
      positions_.push_back(TeammatePosition(mate, start_mission_s + i * dt));
    }
  }
}

int SeparationSampler::Samples(const PolynomialTrajectory& trajectory) const {
  if (teammates_.empty()) return 0;
  const double dt = dt_;
  const double span =
      SeparationHorizon(trajectory, start_mission_s_, teammates_) - start_mission_s_;
  const int samples = static_cast<int>(std::floor(span / dt)) + 1;
  const std::size_t mates = teammates_.size();
  int count = 0;
  for (int i = 0; i <= samples; ++i) {
    const bool on_grid = i * dt <= span;  // else the last sample, at span itself
    const double t = std::min(i * dt, span);
    const Vec3 p = trajectory.Position(t);
    for (std::size_t m = 0; m < mates; ++m) {
      const Vec3 there = !on_grid    ? TeammatePosition(teammates_[m], start_mission_s_ + t)
                         : i < grid_ ? positions_[static_cast<std::size_t>(i) * mates + m]
                                     : end_[m];
      if (!Separated(p, there,
                     RequiredDistance(teammates_[m], start_mission_s_ + t, min_separation_m_))) {
        ++count;
        break;
      }
    }
  }
  return count;
}

int SeparationSamples(const PolynomialTrajectory& trajectory, double start_mission_s,
                      std::span<const Teammate> teammates, double min_separation_m,
                      double rate_hz) {
  return SeparationSampler(start_mission_s, teammates, min_separation_m, rate_hz)
      .Samples(trajectory);
}

absl::Status CheckSeparationExact(const PolynomialTrajectory& trajectory, double start_mission_s,
                                  std::span<const Teammate> teammates, double min_separation_m,
                                  double spacing_m) {
  const double own_speed = trajectory.MaxSpeed();
  for (const Teammate& mate : teammates) {
    // The slack's rate of change is at most the sum of the speeds plus the
    // rate at which a silent teammate's reach grows.
    const double v = std::max(own_speed + TimelineMaxSpeed(mate) + mate.drift_m_s, 1e-3);
    const double dt = spacing_m / v;
    const double margin = 0.5 * v * dt;
    const double from = start_mission_s;
    const double to = std::max(from, SeparationHorizon(trajectory, start_mission_s, {&mate, 1}));
    const int steps = std::max(1, static_cast<int>(std::ceil((to - from) / dt)));
    const double step = (to - from) / steps;
    for (int i = 0; i <= steps; ++i) {
      const double t = from + i * step;
      const double d = (trajectory.Position(t - from) - TeammatePosition(mate, t)).norm();
      const double required = RequiredDistance(mate, t, min_separation_m);
      if (d < required + margin) {
        return absl::FailedPreconditionError(absl::StrFormat(
            "path comes within %.2f m of UAV '%s' at mission time %.2f s (it must keep %.2f m: "
            "min_separation_m %g, the two bodies and tracking%s)",
            d, mate.uav_id, t, required, min_separation_m,
            t > mate.drift_from_s ? ", and how far the silent UAV may have drifted" : ""));
      }
    }
  }
  return absl::OkStatus();
}

}  // namespace oaipp
