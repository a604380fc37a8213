// When the camera fires along a trajectory (docs/method.md §4.5, §5).
//
// The sensor fires at a constant rate over MISSION time, not trajectory
// time: when the planner replaces the trajectory, the next shot keeps its
// time, so replanning neither delays nor hurries measurements. Each call
// covers one trajectory and hands the phase on to the next.
//
//   double next_shot_mission_s = 0.0;  // first shot at mission start
//   OAIPP_ASSIGN_OR_RETURN(MeasurementSchedule shots,
//       ScheduleMeasurements({.trajectory_start_mission_s = t0_s,
//                             .duration_s = traj.Duration(),
//                             .rate_hz = 0.15,
//                             .next_shot_mission_s = next_shot_mission_s}));
//   for (double t_s : shots.times_s) Measure(traj.Position(t_s));
//   next_shot_mission_s = shots.next_shot_mission_s;  // for the next trajectory
#pragma once

#include <vector>

#include "absl/status/statusor.h"

namespace oaipp {

// The stretch of mission time one trajectory covers, and the camera's rate
// and phase: what ScheduleMeasurements places shots in.
struct ShotWindow {
  // Mission time at which the trajectory starts, seconds. Valid: finite.
  double trajectory_start_mission_s = 0.0;
  // Trajectory duration, seconds. Valid: >= 0 and finite.
  double duration_s = 0.0;
  // Shots per second. Valid: > 0 and finite (0.15 Hz in the paper).
  double rate_hz = 0.15;
  // Mission time of the next shot carried over from the previous
  // trajectory (or the first shot of the mission). Valid: finite. If it is
  // before trajectory_start_mission_s, the shots that fell before the start
  // are skipped, keeping the phase.
  double next_shot_mission_s = 0.0;
};

struct MeasurementSchedule {
  // Shot times relative to the trajectory start, increasing, in the
  // half-open [0, duration_s): a shot exactly at the end belongs to the
  // next trajectory, which starts there, so no shot is taken twice.
  std::vector<double> times_s;
  // Mission time of the first shot after this trajectory: pass it as the
  // next window's next_shot_mission_s.
  double next_shot_mission_s = 0.0;
};

// The shots at mission times next_shot_mission_s + j / rate_hz that fall in
// [start, start + duration). Shot times are accumulated one period at a
// time in mission time, so splitting a mission into consecutive
// trajectories reproduces the mission times of one long trajectory bit for
// bit. Returns InvalidArgument naming the field for non-finite numbers, a
// negative duration, a rate that is not positive, or more than 10^7 shots.
[[nodiscard]] absl::StatusOr<MeasurementSchedule> ScheduleMeasurements(const ShotWindow& window);

}  // namespace oaipp
