// A piecewise polynomial trajectory in the world frame: one degree-9
// polynomial per segment and axis, as produced by the minimum-snap solver
// (core/trajectory/min_snap.h, docs/method.md §5).
//
// Time t_s runs from 0 at the first waypoint to Duration() at the last.
// Segment i spans [SegmentStartTime(i), SegmentStartTime(i) + T_i]; queries
// outside [0, Duration()] are clamped to the nearest end. The trajectory is
// a small value type (about 250 bytes per segment): copy it freely. It is
// built only by SolveMinSnap / PlanMinSnap, so it always satisfies their
// continuity and boundary conditions.
//
//   OAIPP_ASSIGN_OR_RETURN(PolynomialTrajectory traj, PlanMinSnap(start, waypoints, limits));
//   Vec3 p_W = traj.Position(0.5 * traj.Duration());
//   double v_max_m_s = traj.MaxSpeed();
//   OAIPP_ASSIGN_OR_RETURN(auto samples, SampleTrajectory(traj, 20.0));  // collision checks
#pragma once

#include <vector>

#include "Eigen/Core"
#include "absl/status/statusor.h"
#include "core/common/geometry.h"

namespace oaipp {

class PolynomialTrajectory {
 public:
  static constexpr int kDegree = 9;
  static constexpr int kNumCoefficients = kDegree + 1;
  // Column a holds axis a (x, y, z); row k the coefficient of tau^k, where
  // tau is the time since the segment's start, seconds.
  using SegmentCoefficients = Eigen::Matrix<double, kNumCoefficients, 3>;

  // A trajectory from real-time coefficients, as Coefficients() gives them
  // (e.g. one received over the API), one block per segment. Continuity is
  // the sender's: it is not checked. Such a trajectory is evaluated on the
  // coefficients as given, in real time (Horner's scheme with derivatives),
  // so what a receiver computes does not depend on a change of basis. InvalidArgument naming the
  // field
  // ("durations_s[2]", "coefficients[0]") when there is no segment, the
  // counts differ, a duration is not positive and finite, or a coefficient
  // is not finite.
  [[nodiscard]] static absl::StatusOr<PolynomialTrajectory> FromCoefficients(
      std::vector<double> durations_s, const std::vector<SegmentCoefficients>& coefficients);

  PolynomialTrajectory(const PolynomialTrajectory&) = default;
  PolynomialTrajectory& operator=(const PolynomialTrajectory&) = default;
  PolynomialTrajectory(PolynomialTrajectory&&) = default;
  PolynomialTrajectory& operator=(PolynomialTrajectory&&) = default;

  [[nodiscard]] int NumSegments() const { return static_cast<int>(durations_s_.size()); }
  // Sum of the segment durations, seconds (> 0).
  [[nodiscard]] double Duration() const { return duration_s_; }
  // T_0 .. T_{N-1}, seconds, each > 0.
  [[nodiscard]] const std::vector<double>& SegmentDurations() const { return durations_s_; }
  // The N + 1 waypoints the trajectory passes through, in order; waypoint i
  // is reached at SegmentStartTime(i) (and the last at Duration()).
  [[nodiscard]] const std::vector<Vec3>& Waypoints() const { return waypoints_W_; }
  // Start time of segment `segment`, seconds. Precondition (asserted):
  // 0 <= segment <= NumSegments() (NumSegments() gives Duration()).
  [[nodiscard]] double SegmentStartTime(int segment) const;

  // Position, velocity and acceleration at time t_s (clamped to
  // [0, Duration()]), in W: m, m/s, m/s^2.
  [[nodiscard]] Vec3 Position(double t_s) const { return Derivative(t_s, 0); }
  [[nodiscard]] Vec3 Velocity(double t_s) const { return Derivative(t_s, 1); }
  [[nodiscard]] Vec3 Acceleration(double t_s) const { return Derivative(t_s, 2); }
  // d^order p / dt^order at t_s (clamped to [0, Duration()]), in m/s^order.
  // Orders 0..4 are continuous across waypoints; higher orders are those of
  // the segment containing t_s (the later one at a waypoint), and orders
  // above kDegree are zero. Precondition (asserted): order >= 0.
  [[nodiscard]] Vec3 Derivative(double t_s, int order) const;

  // Coefficients of segment `segment` in real time since the segment start
  // (lowest order first), so that p_a(tau) = sum_k C(k, a) tau^k for tau in
  // [0, T_segment]. Precondition (asserted): 0 <= segment < NumSegments().
  [[nodiscard]] SegmentCoefficients Coefficients(int segment) const;

  // Integral over the whole trajectory of |d^4 p / dt^4|^2, m^2/s^7, in
  // closed form (sum over segments and axes of c^T Q c / T^7, Richter et al.
  // 2016, the cost matrix Q of their Sec. 3 in normalised time).
  [[nodiscard]] double SnapCost() const;

  // Maximum over t of |velocity| (m/s) and |acceleration| (m/s^2). Each
  // segment is sampled at 65 evenly spaced times and every sampled local
  // maximum of the squared norm (a polynomial) is refined by golden-section
  // search to ~2e-8 of the segment duration, so the result is the true
  // maximum to ~1e-12 relative unless two local maxima lie within 1/64 of a
  // segment's duration of each other (then the lower one may be
  // under-estimated by at most its variation over that interval). Never
  // larger than the true maximum.
  [[nodiscard]] double MaxSpeed() const { return MaxNorm(1); }
  [[nodiscard]] double MaxAcceleration() const { return MaxNorm(2); }

 private:
  using NormalizedCoefficients = Eigen::Matrix<double, kNumCoefficients, 3>;

  // Coefficients are in normalised time s = tau / T (see
  // internal/polynomial_basis.h), one block per segment.
  PolynomialTrajectory(std::vector<Vec3> waypoints_W, std::vector<double> durations_s,
                       std::vector<NormalizedCoefficients> coefficients);

  [[nodiscard]] int SegmentIndex(double t_s) const;
  [[nodiscard]] double MaxNorm(int order) const;

  std::vector<Vec3> waypoints_W_;
  std::vector<double> durations_s_;
  std::vector<double> start_times_s_;  // N + 1 entries, the last = Duration()
  std::vector<NormalizedCoefficients> coefficients_;
  // Set only by FromCoefficients: the real-time coefficients as given, which
  // Derivative and Coefficients then use.
  std::vector<SegmentCoefficients> real_time_coefficients_;
  double duration_s_ = 0.0;

  friend absl::StatusOr<PolynomialTrajectory> SolveMinSnap(
      const std::vector<Vec3>& waypoints_W, const std::vector<double>& segment_durations_s,
      const Vec3& start_velocity_W_m_s, const Vec3& start_accel_W_m_s2, bool free_start_jerk_snap);
};

// A position on the trajectory and when it is reached (seconds since the
// trajectory start).
struct TimedPosition {
  double t_s = 0.0;
  Vec3 position_W = Vec3::Zero();
};

// Samples the trajectory at t = 0, 1/rate, 2/rate, ... (< Duration()) and at
// Duration() itself, so both ends are always included (e.g. 20 Hz for
// collision checks along the path). InvalidArgument unless rate_hz is
// positive and finite, or if the sample count would exceed 10^7.
[[nodiscard]] absl::StatusOr<std::vector<TimedPosition>> SampleTrajectory(
    const PolynomialTrajectory& trajectory, double rate_hz);

}  // namespace oaipp
