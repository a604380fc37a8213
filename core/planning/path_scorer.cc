#include "core/planning/path_scorer.h"

#include <cmath>
#include <optional>
#include <span>

#include "absl/strings/str_cat.h"
#include "core/common/field_error.h"
#include "core/common/status_macros.h"
#include "core/planning/separation.h"
#include "core/trajectory/measurement_schedule.h"

namespace oaipp {
namespace {

// Shots closer than this to the start are taken where the UAV already is.
constexpr double kStartShotTolerance_s = 1e-9;

}  // namespace

absl::Status PlannerLimits::Validate() const {
  OAIPP_RETURN_IF_ERROR(ValidateLimits(dynamics));
  OAIPP_RETURN_IF_ERROR(CheckPositive("limits.uav_radius_m", uav_radius_m));
  if (!(tracking_error_m >= 0.0 && tracking_error_m <= 10.0)) {
    return FieldError(absl::StatusCode::kInvalidArgument,
                      absl::StrCat("$0: must be in [0, 10], got ", tracking_error_m),
                      {"limits.tracking_error_m"});
  }
  OAIPP_RETURN_IF_ERROR(CheckPositive("limits.collision_sample_rate_hz", collision_sample_rate_hz));
  return CheckPositive("limits.exact_check_spacing_m", exact_check_spacing_m);
}

namespace {

// `area` (over `field`) on the cells of `window`, a block of the field's
// cells: each window cell takes its centre's field cell.
std::vector<std::uint8_t> AreaOnWindow(std::span<const std::uint8_t> area, const FieldGrid& field,
                                       const FieldGrid& window) {
  std::vector<std::uint8_t> out(static_cast<std::size_t>(window.num_cells()), 0);
  for (int c = 0; c < window.num_cells(); ++c) {
    const std::optional<int> cell = field.CellOf(window.CellCentreXY(c));
    if (cell.has_value()) out[static_cast<std::size_t>(c)] = area[static_cast<std::size_t>(*cell)];
  }
  return out;
}

}  // namespace

PathScorer::PathScorer(const PlanningContext& mission, const UavState& state,
                       const PlannerLimits& limits, const InformationParams& information,
                       const ScoreWeights& weights)
    : mission_(mission),
      state_(state),
      limits_(limits),
      weights_(weights),
      window_area_(!mission.search_area.empty() && mission.field != nullptr &&
                           mission.field != &mission.map->grid()
                       ? AreaOnWindow(mission.search_area, *mission.field, mission.map->grid())
                       : std::vector<std::uint8_t>{}),
      evaluator_(
          mission.map->Mean(), mission.map->Covariance(), information,
          window_area_.empty() ? mission.search_area : std::span<const std::uint8_t>(window_area_)),
      waypoint_box_(mission.environment->flight_volume().Inflated(-0.5 * limits.uav_radius_m)) {}

absl::Status PlannerCommon::Validate() const {
  OAIPP_RETURN_IF_ERROR(limits.Validate());
  OAIPP_RETURN_IF_ERROR(information.Validate());
  if (!(weights.k1 >= 0) || !(weights.k2 >= 0) || !std::isfinite(weights.k1) ||
      !std::isfinite(weights.k2)) {
    return absl::InvalidArgumentError("weights.k1, weights.k2: must be >= 0 and finite");
  }
  return CheckPositive("weights.min_flight_time_s", weights.min_flight_time_s);
}

absl::StatusOr<PathScorer> PathScorer::Create(const PlanningContext& mission, const UavState& state,
                                              const PlannerCommon& common) {
  const PlannerLimits& limits = common.limits;
  if (mission.environment == nullptr)
    return absl::InvalidArgumentError("mission.environment: missing");
  if (mission.map == nullptr) return absl::InvalidArgumentError("mission.map: missing");
  if (mission.map->num_cells() == 0) return absl::InvalidArgumentError("mission.map: empty field");
  OAIPP_RETURN_IF_ERROR(common.Validate());
  OAIPP_RETURN_IF_ERROR(mission.camera.Validate());

  const Aabb& volume = mission.environment->flight_volume();
  const FieldGrid& grid = mission.map->grid();
  const FieldGrid& field = mission.field != nullptr ? *mission.field : grid;
  if (!mission.search_area.empty() &&
      mission.search_area.size() != static_cast<std::size_t>(field.num_cells())) {
    return absl::InvalidArgumentError(
        absl::StrCat("mission.search_area: ", mission.search_area.size(), " cells for a field of ",
                     field.num_cells()));
  }
  if ((grid.max_W().array() <= volume.min_W.head<2>().array()).any() ||
      (grid.min_W().array() >= volume.max_W.head<2>().array()).any()) {
    return absl::InvalidArgumentError("mission.map: the field lies outside the flight volume");
  }
  OAIPP_RETURN_IF_ERROR(CheckFinite("state.position_W", state.position_W));
  OAIPP_RETURN_IF_ERROR(CheckFinite("state.velocity_W_m_s", state.velocity_W_m_s));
  OAIPP_RETURN_IF_ERROR(CheckFinite("state.accel_W_m_s2", state.accel_W_m_s2));
  OAIPP_RETURN_IF_ERROR(CheckFinite("state.mission_time_s", state.mission_time_s));
  OAIPP_RETURN_IF_ERROR(CheckFinite("mission.next_shot_mission_s", mission.next_shot_mission_s));
  // What the request says is checked first (InvalidArgument); what the
  // mission's present state refuses comes after (FailedPrecondition: the
  // flight time spent, an obstacle or a teammate where the UAV is).
  if (mission.next_shot_mission_s < state.mission_time_s - 1e-9) {
    return FieldError(
        absl::StatusCode::kInvalidArgument,
        absl::StrCat("$0: ", mission.next_shot_mission_s, " lies before $1 ", state.mission_time_s),
        {"mission.next_shot_mission_s", "state.mission_time_s"});
  }
  if (!volume.Contains(state.position_W, 1e-6)) {
    const Vec3& p = state.position_W;
    return FieldError(
        absl::StatusCode::kInvalidArgument,
        absl::StrCat("$0: (", p.x(), ", ", p.y(), ", ", p.z(), ") lies outside the flight volume"),
        {"state.position_W"});
  }
  if (state.velocity_W_m_s.norm() > limits.dynamics.max_speed_m_s * (1 + 1e-6)) {
    return FieldError(absl::StatusCode::kInvalidArgument, "$0: faster than $1",
                      {"state.velocity_W_m_s", "limits.max_speed_m_s"});
  }
  if (state.accel_W_m_s2.norm() > limits.dynamics.max_accel_m_s2 * (1 + 1e-6)) {
    return FieldError(absl::StatusCode::kInvalidArgument, "$0: beyond $1",
                      {"state.accel_W_m_s2", "limits.max_accel_m_s2"});
  }
  if (!(mission.remaining_budget_s > 0.0)) {
    return FieldError(absl::StatusCode::kFailedPrecondition,
                      absl::StrCat("$0: no flight time left (", mission.remaining_budget_s, " s)"),
                      {"mission.remaining_budget_s"});
  }
  const double clearance = mission.environment->SignedDistance(state.position_W);
  if (clearance < 0.0) {
    return FieldError(absl::StatusCode::kFailedPrecondition, "$0: lies inside an obstacle",
                      {"state.position_W"});
  }
  if (clearance < limits.ObstacleClearance()) {
    return FieldError(absl::StatusCode::kFailedPrecondition,
                      absl::StrCat("$0: only ", clearance, " m from an obstacle, closer than the ",
                                   limits.ObstacleClearance(), " m a path keeps (",
                                   ClearanceRuleName(limits), ")"),
                      {"state.position_W"});
  }
  if (!mission.teammates.empty()) {
    if (!(mission.min_separation_m > 0.0) || !std::isfinite(mission.min_separation_m)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "mission.min_separation_m: must be positive and finite, got ", mission.min_separation_m));
    }
    // The final check's own margin included (CheckSeparationExact), so
    // that a start this accepts can be planned from.
    for (const Teammate& mate : mission.teammates) {
      const Vec3 there = TeammatePosition(mate, state.mission_time_s);
      const double required =
          RequiredDistance(mate, state.mission_time_s, mission.min_separation_m) +
          0.5 * limits.exact_check_spacing_m;
      if (!Separated(state.position_W, there, required)) {
        return FieldError(
            absl::StatusCode::kFailedPrecondition,
            absl::StrCat("$0: ", (state.position_W - there).norm(), " m from UAV '",
                         EscapeForFieldError(mate.uav_id), "', closer than the ", required,
                         " m the two must keep (min_separation_m ", mission.min_separation_m, ")"),
            {"state.position_W"});
      }
    }
  }
  PathScorer scorer(mission, state, limits,
                    common.information.ForRemainingBudget(mission.remaining_budget_s),
                    common.weights);
  // Teammates' shots still to come count as taken (unscored) before any of
  // this UAV's, so that it does not plan to look at the same ground.
  for (const Teammate& mate : mission.teammates) {
    const DownwardCamera& camera = mate.camera.has_value() ? *mate.camera : mission.camera;
    const SensorNoise& noise = mate.noise.has_value() ? *mate.noise : mission.noise;
    for (const Vec3& p : mate.pending_shots_W) {
      PoseObservation shot = scorer.ObserveWith(camera, noise, p, /*scored=*/false);
      if (!shot.cells.empty()) scorer.start_observations_.push_back(std::move(shot));
    }
  }
  scorer.teammate_observations_ = scorer.start_observations_.size();
  if (!mission.teammates.empty()) {
    scorer.separation_.emplace(state.mission_time_s, scorer.mission_.teammates,
                               mission.min_separation_m, limits.collision_sample_rate_hz);
  }
  if (mission.next_shot_mission_s - state.mission_time_s < kStartShotTolerance_s) {
    scorer.start_observations_.push_back(scorer.Observe(state.position_W, /*scored=*/false));
  }
  if (!scorer.start_observations_.empty()) {
    // Every candidate fuses these shots first: condition on them once.
    OAIPP_RETURN_IF_ERROR(scorer.evaluator_.Condition(scorer.start_observations_,
                                                      mission.conditioned, mission.chain));
  }
  return scorer;
}

PoseObservation PathScorer::Observe(const Vec3& p_W, bool scored) const {
  return ObserveWith(mission_.camera, mission_.noise, p_W, scored);
}

PoseObservation PathScorer::ObserveWith(const DownwardCamera& camera, const SensorNoise& noise,
                                        const Vec3& p_W, bool scored) const {
  PoseObservation obs;
  obs.altitude_m = p_W.z();
  obs.variance = noise.Variance(std::max(p_W.z(), 1e-3));
  // Without a detector model, a person in view is seen (the detection
  // objective's h_sat still bounds the altitude).
  obs.detection_probability =
      noise.detector.has_value() ? noise.detector->DetectionProbability(p_W.z()) : 1.0;
  obs.cells = camera.VisibleFootprintCells(grid(), p_W, mission_.environment);
  obs.scored = scored;
  return obs;
}

ScoredPath PathScorer::Score(const std::vector<Vec3>& waypoints_W) const {
  StartState start{state_.position_W, state_.velocity_W_m_s, state_.accel_W_m_s2};
  absl::StatusOr<PolynomialTrajectory> traj = PlanMinSnap(start, waypoints_W, limits_.dynamics);
  if (!traj.ok()) return ScoredPath{};
  return ScoreTrajectory(*std::move(traj));
}

ScoredPath PathScorer::ScoreTrajectory(PolynomialTrajectory trajectory) const {
  ScoredPath out;
  absl::StatusOr<MeasurementSchedule> shots = ScheduleMeasurements(
      {.trajectory_start_mission_s = state_.mission_time_s,
       .duration_s = trajectory.Duration(),
       .rate_hz = mission_.camera.rate_hz,
       .next_shot_mission_s = std::max(mission_.next_shot_mission_s, state_.mission_time_s)});
  if (!shots.ok()) return out;

  // The conditioned prefix, exactly: the evaluator skips it only when the
  // poses begin with it bit for bit. The shot due at the start is the one
  // Create observed at state.position_W, not one at trajectory.Position(t)
  // for a t within kStartShotTolerance_s of 0, whose altitude may differ in
  // the last bits (then every pose, teammates' included, would be fused
  // again on the unconditioned covariance: the same value, at tens of times
  // the cost).
  const bool start_shot = start_observations_.size() > teammate_observations_;
  std::vector<PoseObservation> observations(start_observations_.begin(), start_observations_.end());
  for (std::size_t i = 0; i < shots->times_s.size(); ++i) {
    const double t = shots->times_s[i];
    const Vec3 p = trajectory.Position(t);
    out.poses.push_back({t, state_.mission_time_s + t, p});
    const bool scored = t >= kStartShotTolerance_s;
    if (i == 0 && start_shot && !scored) continue;  // in the prefix already
    observations.push_back(Observe(p, scored));
  }
  out.information = evaluator_.Evaluate(observations);

  // C_coll (Eq. 3), on the ESDF: every candidate pays it.
  out.collision_samples = CollisionSamples(trajectory, /*exact=*/false);
  out.score = Objective(out.information, out.collision_samples, trajectory.Duration());
  out.next_shot_mission_s = shots->next_shot_mission_s;
  out.trajectory = std::move(trajectory);
  return out;
}

absl::Status CheckTrajectoryExact(const Environment& env, const PolynomialTrajectory& trajectory,
                                  const PlannerLimits& limits) {
  const double speed = std::max(trajectory.MaxSpeed(), 1e-3);
  const double dt = limits.exact_check_spacing_m / speed;
  // A curve with |acceleration| <= a leaves its chord over dt by at most
  // a dt^2 / 8.
  const double bulge = trajectory.MaxAcceleration() * dt * dt / 8.0;
  const double clearance = limits.ObstacleClearance() + bulge;
  const int steps = static_cast<int>(std::ceil(trajectory.Duration() / dt));
  Vec3 previous = trajectory.Position(0.0);
  for (int i = 1; i <= steps; ++i) {
    const double t = std::min(i * trajectory.Duration() / steps, trajectory.Duration());
    const Vec3 p = trajectory.Position(t);
    if (!env.flight_volume().Contains(p, -bulge)) {
      return absl::FailedPreconditionError(
          absl::StrCat("path leaves the flight volume at t = ", t, " s"));
    }
    if (!env.IsSegmentClear(previous, p, clearance)) {
      return absl::FailedPreconditionError(absl::StrCat("path comes closer than ",
                                                        ClearanceRuleName(limits),
                                                        " to an obstacle near t = ", t, " s"));
    }
    previous = p;
  }
  return absl::OkStatus();
}

absl::Status PathScorer::CheckExact(const PolynomialTrajectory& trajectory) const {
  OAIPP_RETURN_IF_ERROR(CheckTrajectoryExact(*mission_.environment, trajectory, limits_));
  if (mission_.teammates.empty()) return absl::OkStatus();
  return CheckSeparationExact(trajectory, state_.mission_time_s, mission_.teammates,
                              mission_.min_separation_m, limits_.exact_check_spacing_m);
}

double PathScorer::Objective(double information, int collision_samples, double duration_s) const {
  const double t_flight = std::max(duration_s, weights_.min_flight_time_s);
  return (weights_.k1 * information - weights_.k2 * collision_samples) / t_flight;
}

int PathScorer::CollisionSamples(const PolynomialTrajectory& trajectory, bool exact) const {
  const Environment& env = *mission_.environment;
  const double dt = 1.0 / limits_.collision_sample_rate_hz;
  const double clearance = limits_.ObstacleClearance();
  const int samples = static_cast<int>(std::floor(trajectory.Duration() / dt)) + 1;
  int count = 0;
  for (int i = 0; i <= samples; ++i) {
    const Vec3 p = trajectory.Position(std::min(i * dt, trajectory.Duration()));
    const bool near = exact ? env.SignedDistance(p) < clearance : env.CloserThan(p, clearance);
    if (!env.flight_volume().Contains(p) || near) ++count;
  }
  // Teammates by the one separation rule, at the same rate (to the last
  // teammate's end, this UAV hovering after its own).
  return count + (separation_.has_value() ? separation_->Samples(trajectory) : 0);
}

PlannedPath PathScorer::Finish(ScoredPath scored, const std::vector<Vec3>& waypoints_W,
                               PlannerStats stats) const {
  // One collision model for a returned path: the exact one its verdict used.
  const int exact = CollisionSamples(*scored.trajectory, /*exact=*/true);
  if (exact != scored.collision_samples) {
    scored.collision_samples = exact;
    scored.score = Objective(scored.information, exact, scored.trajectory->Duration());
  }
  std::vector<Vec3> control{state_.position_W};
  control.insert(control.end(), waypoints_W.begin(), waypoints_W.end());
  return PlannedPath{.trajectory = std::move(*scored.trajectory),
                     .control_waypoints_W = std::move(control),
                     .measurement_poses = std::move(scored.poses),
                     .objective = scored.score,
                     .information = scored.information,
                     .collision_samples = scored.collision_samples,
                     .collision_free = true,
                     .next_shot_mission_s = scored.next_shot_mission_s,
                     .stats = std::move(stats)};
}

}  // namespace oaipp
