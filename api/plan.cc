#include "api/plan.h"

#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "api/geometry.h"
#include "core/common/status_macros.h"

namespace oaipp::api {

namespace {

// `trajectory` into *t: segments, duration and samples.
void WriteTrajectory(const PolynomialTrajectory& trajectory, v1::Trajectory& t) {
  const double duration_s = trajectory.Duration();
  t.set_duration_s(duration_s);
  std::vector<PolynomialTrajectory::SegmentCoefficients> sent;
  for (int i = 0; i < trajectory.NumSegments(); ++i) {
    const PolynomialTrajectory::SegmentCoefficients& c =
        sent.emplace_back(trajectory.Coefficients(i));
    v1::PolynomialSegment& segment = *t.add_segments();
    segment.set_duration_s(trajectory.SegmentDurations()[i]);
    for (int k = 0; k < PolynomialTrajectory::kNumCoefficients; ++k) {
      segment.add_x_coefficients(c(k, 0));
      segment.add_y_coefficients(c(k, 1));
      segment.add_z_coefficients(c(k, 2));
    }
  }
  // The samples are what the coefficients as sent give (TrajectoryFromProto
  // of this response reproduces them bit for bit). Returned paths are finite
  // and bounded in length, so both steps succeed.
  absl::StatusOr<PolynomialTrajectory> as_sent =
      PolynomialTrajectory::FromCoefficients(trajectory.SegmentDurations(), sent);
  absl::StatusOr<std::vector<TimedPosition>> samples =
      as_sent.ok() ? SampleTrajectory(*as_sent, kTrajectorySampleRate_hz)
                   : absl::StatusOr<std::vector<TimedPosition>>(as_sent.status());
  if (samples.ok()) {
    for (const TimedPosition& sample : *samples) {
      v1::TrajectorySample& s = *t.add_samples();
      s.set_t_s(sample.t_s);
      *s.mutable_position_m() = ToProto(sample.position_W);
      *s.mutable_velocity_m_s() = ToProto(as_sent->Velocity(sample.t_s));
    }
  }
}

}  // namespace

void PlannedPathToProto(const PlannedPath& path, v1::PlanPathResponse* out) {
  out->Clear();
  WriteTrajectory(path.trajectory, *out->mutable_trajectory());
  for (const Vec3& c : path.control_waypoints_W) *out->add_control_waypoints_m() = ToProto(c);
  for (const MeasurementPose& pose : path.measurement_poses) {
    v1::MeasurementPose& p = *out->add_measurement_poses();
    p.set_t_s(pose.t_s);
    p.set_mission_time_s(pose.mission_time_s);
    *p.mutable_position_m() = ToProto(pose.position_W);
  }
  out->set_objective(path.objective);
  out->set_information(path.information);
  out->set_collision_samples(path.collision_samples);
  out->set_collision_free(path.collision_free);
  out->set_next_shot_mission_s(path.next_shot_mission_s);
  v1::PlannerStats& stats = *out->mutable_stats();
  stats.set_evaluations(path.stats.evaluations);
  stats.set_generations(path.stats.generations);
  stats.set_wall_time_s(path.stats.wall_time_s);
  stats.set_stop_reason(path.stats.stop_reason);
  stats.set_initial_objective(path.stats.initial_objective);
  stats.set_stop_first_s(path.stats.stop_first_s);
  stats.set_search_fraction(path.stats.search_fraction);
  stats.set_queued_s(path.stats.queued_s);
  stats.set_search_budget_s(path.stats.search_budget_s);
  if (path.way_home.has_value()) WriteTrajectory(*path.way_home, *out->mutable_way_home());
  if (path.remaining_after_return_s.has_value()) {
    out->set_remaining_after_return_s(*path.remaining_after_return_s);
  }
  out->set_returning_home(path.returning_home);
  if (!path.team.uav_id.empty()) {
    out->set_uav_id(path.team.uav_id);
    out->set_plan_version(path.team.plan_version);
    out->set_start_mission_s(path.team.start_mission_s);
    for (const auto& [uav_id, version] : path.team.checked_against) {
      v1::TeammatePlan& mate = *out->add_checked_against();
      mate.set_uav_id(uav_id);
      mate.set_plan_version(version);
      if (auto it = path.team.shots_counted.find(uav_id); it != path.team.shots_counted.end()) {
        mate.set_shots_counted(it->second);
      }
    }
  }
}

absl::StatusOr<PolynomialTrajectory> TrajectoryFromProto(const v1::Trajectory& trajectory) {
  std::vector<double> durations_s;
  std::vector<PolynomialTrajectory::SegmentCoefficients> coefficients;
  durations_s.reserve(trajectory.segments_size());
  coefficients.reserve(trajectory.segments_size());
  constexpr int kCount = PolynomialTrajectory::kNumCoefficients;
  for (int i = 0; i < trajectory.segments_size(); ++i) {
    const v1::PolynomialSegment& segment = trajectory.segments(i);
    const google::protobuf::RepeatedField<double>* axes[] = {
        &segment.x_coefficients(), &segment.y_coefficients(), &segment.z_coefficients()};
    PolynomialTrajectory::SegmentCoefficients c = PolynomialTrajectory::SegmentCoefficients::Zero();
    for (int a = 0; a < 3; ++a) {
      if (axes[a]->size() > kCount) {
        return absl::InvalidArgumentError(
            absl::StrCat("trajectory.segments[", i, "].", std::string(1, "xyz"[a]),
                         "_coefficients: has ", axes[a]->size(), ", at most ", kCount));
      }
      for (int k = 0; k < axes[a]->size(); ++k) c(k, a) = axes[a]->Get(k);
    }
    if (!c.allFinite()) {
      return absl::InvalidArgumentError(
          absl::StrCat("trajectory.segments[", i, "]: coefficients must be finite"));
    }
    OAIPP_RETURN_IF_ERROR(CheckPositive(absl::StrCat("trajectory.segments[", i, "].duration_s"),
                                        segment.duration_s()));
    durations_s.push_back(segment.duration_s());
    coefficients.push_back(c);
  }
  if (durations_s.empty()) {
    return absl::InvalidArgumentError("trajectory.segments: needs at least one segment");
  }
  return PolynomialTrajectory::FromCoefficients(std::move(durations_s), coefficients);
}

absl::StatusOr<PlannedPath> PlannedPathFromProto(const v1::PlanPathResponse& response) {
  OAIPP_ASSIGN_OR_RETURN(PolynomialTrajectory trajectory,
                         TrajectoryFromProto(response.trajectory()));
  PlannedPath path{.trajectory = std::move(trajectory)};
  for (const v1::Vector3& c : response.control_waypoints_m()) {
    path.control_waypoints_W.push_back(FromProto(c));
  }
  for (const v1::MeasurementPose& p : response.measurement_poses()) {
    path.measurement_poses.push_back({.t_s = p.t_s(),
                                      .mission_time_s = p.mission_time_s(),
                                      .position_W = FromProto(p.position_m())});
  }
  path.objective = response.objective();
  path.information = response.information();
  path.collision_samples = response.collision_samples();
  path.collision_free = response.collision_free();
  path.next_shot_mission_s = response.next_shot_mission_s();
  path.stats = {.evaluations = response.stats().evaluations(),
                .generations = response.stats().generations(),
                .wall_time_s = response.stats().wall_time_s(),
                .stop_reason = response.stats().stop_reason(),
                .initial_objective = response.stats().initial_objective(),
                .stop_first_s = response.stats().stop_first_s(),
                // Plans stored before the field existed ran their whole search.
                .search_fraction = response.stats().search_fraction() > 0.0
                                       ? response.stats().search_fraction()
                                       : 1.0,
                .queued_s = response.stats().queued_s(),
                .search_budget_s = response.stats().search_budget_s()};
  if (response.has_way_home()) {
    OAIPP_ASSIGN_OR_RETURN(path.way_home, TrajectoryFromProto(response.way_home()));
  }
  if (response.has_remaining_after_return_s()) {
    path.remaining_after_return_s = response.remaining_after_return_s();
  }
  path.returning_home = response.returning_home();
  path.team.uav_id = response.uav_id();
  path.team.plan_version = response.plan_version();
  path.team.start_mission_s = response.start_mission_s();
  for (const v1::TeammatePlan& mate : response.checked_against()) {
    path.team.checked_against.emplace_back(mate.uav_id(), mate.plan_version());
    if (mate.shots_counted() > 0) path.team.shots_counted[mate.uav_id()] = mate.shots_counted();
  }
  return path;
}

v1::UavState StateAlongPath(const PolynomialTrajectory& trajectory, double t_s,
                            double start_mission_time_s) {
  return UavStateToProto(StateAlong(trajectory, t_s, start_mission_time_s));
}

}  // namespace oaipp::api
