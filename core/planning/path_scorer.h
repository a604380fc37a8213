// Scoring candidate paths for every planner (docs/method.md §6, Eq. 1):
//   score = (k1 O_info - k2 C_coll) / t_flight.
//
// PathScorer validates the mission and the UAV state once per replan, then
// turns control waypoints into a minimum-snap trajectory, its measurement
// poses, their visible cells, the information value and the collision cost.
// It also runs the final exact collision check.
//
//   OAIPP_ASSIGN_OR_RETURN(PathScorer scorer, PathScorer::Create(view, state, common));
//   ScoredPath s = scorer.Score({c2_W, c3_W});
//   if (s.ok() && scorer.CheckExact(*s.trajectory).ok()) ...
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "core/planning/information.h"
#include "core/planning/planner.h"
#include "core/planning/separation.h"

namespace oaipp {

struct ScoreWeights {
  double k1 = 1.0;    // weight of O_info. Valid: >= 0.
  double k2 = 100.0;  // weight of C_coll, per colliding sample. Valid: >= 0.
  // Floor of t_flight in the score, seconds: keeps a near-zero-length path
  // from dividing by almost nothing. Valid: > 0.
  double min_flight_time_s = 0.5;
};

struct ScoredPath {
  std::optional<PolynomialTrajectory> trajectory;  // empty when infeasible
  std::vector<MeasurementPose> poses;
  double next_shot_mission_s = 0.0;
  double information = 0.0;
  int collision_samples = 0;
  double score = -1e18;  // very low when infeasible
  [[nodiscard]] bool ok() const { return trajectory.has_value(); }
};

// Settings every planner takes.
struct PlannerCommon {
  PlannerLimits limits = {};
  InformationParams information = {};  // the objective (planners that don't optimise it report it)
  ScoreWeights weights = {};
  // Seed of every random choice; mixed with the mission time per replan.
  std::uint32_t seed = 1;
  [[nodiscard]] absl::Status Validate() const;
};

// The exact collision check of a trajectory (docs/method.md §7.4): chords
// every exact_check_spacing_m of travel keep uav_radius_m / 2 plus the
// chord's largest possible bulge from every obstacle, and every sample lies
// in the flight volume shrunk by that bulge. FailedPrecondition naming
// the time otherwise.
[[nodiscard]] absl::Status CheckTrajectoryExact(const Environment& environment,
                                                const PolynomialTrajectory& trajectory,
                                                const PlannerLimits& limits);

class PathScorer {
 public:
  // Validates everything a plan depends on. InvalidArgument naming the field
  // for: missing environment or map, a map whose field misses the flight
  // volume, bad limits or parameters, a non-finite state, a start outside
  // the flight volume, inside an obstacle or closer than r_uav / 2 to one, a
  // start speed or acceleration beyond the limits, a next shot before now.
  [[nodiscard]] static absl::StatusOr<PathScorer> Create(const PlanningContext& mission,
                                                         const UavState& state,
                                                         const PlannerCommon& common);
  // Move-only: the evaluator reads window_area_ through a span, which a
  // move keeps pointing at the moved buffer and a copy would not.
  PathScorer(PathScorer&&) = default;
  PathScorer& operator=(PathScorer&&) = default;
  PathScorer(const PathScorer&) = delete;
  PathScorer& operator=(const PathScorer&) = delete;

  // The trajectory from the UAV state through `waypoints_W` (after the
  // start) and its score.
  [[nodiscard]] ScoredPath Score(const std::vector<Vec3>& waypoints_W) const;
  // The score of a given trajectory from the UAV state (its start must be
  // the state's position, velocity and acceleration; the caller's promise).
  [[nodiscard]] ScoredPath ScoreTrajectory(PolynomialTrajectory trajectory) const;

  // The measurement taken at p_W: visible footprint cells and var(h).
  [[nodiscard]] PoseObservation Observe(const Vec3& p_W, bool scored = true) const;
  // The same taken by another camera with another noise (a teammate's).
  [[nodiscard]] PoseObservation ObserveWith(const DownwardCamera& camera, const SensorNoise& noise,
                                            const Vec3& p_W, bool scored) const;
  // O_info of `poses` given the map.
  [[nodiscard]] double Information(std::span<const PoseObservation> poses) const {
    return evaluator_.Evaluate(poses);
  }
  // For valuing many single scored shots after one fused `history` (adaptive
  // objective only): PoseValue(shot, PosteriorVariances(history)) equals
  // Information(history + {shot}).
  [[nodiscard]] bool adaptive() const { return evaluator_.kind() == ObjectiveKind::kAdaptive; }
  [[nodiscard]] Eigen::VectorXd PosteriorVariances(std::span<const PoseObservation> history) const {
    return evaluator_.PosteriorVariances(history);
  }
  [[nodiscard]] double PoseValue(const PoseObservation& shot,
                                 const Eigen::VectorXd& variances) const {
    return evaluator_.PoseValue(shot, variances);
  }

  // OK when every point of the trajectory stays inside the flight volume
  // and at least r_uav / 2 from every obstacle under the exact geometry
  // (chords between samples <= exact_check_spacing_m apart, widened by the
  // largest possible bulge of the curve over a chord); otherwise
  // FailedPrecondition saying where.
  [[nodiscard]] absl::Status CheckExact(const PolynomialTrajectory& trajectory) const;

  // Assembles the returned path (after CheckExact passed). Its C_coll is
  // counted again at the same samples with the exact distance instead of
  // the ESDF's estimate, and the objective with it, so that a returned path
  // reports the collision cost of the geometry its verdict came from (the
  // ESDF may underestimate a clearance by up to half a voxel diagonal).
  [[nodiscard]] PlannedPath Finish(ScoredPath scored, const std::vector<Vec3>& waypoints_W,
                                   PlannerStats stats) const;

  [[nodiscard]] const UavState& state() const { return state_; }
  [[nodiscard]] const PlannerLimits& limits() const { return limits_; }
  [[nodiscard]] const ScoreWeights& weights() const { return weights_; }
  [[nodiscard]] const Environment& environment() const { return *mission_.environment; }
  [[nodiscard]] const FieldGrid& grid() const { return mission_.map->grid(); }
  // The whole field (PlanningContext::field, else grid()).
  [[nodiscard]] const FieldGrid& field() const {
    return mission_.field != nullptr ? *mission_.field : grid();
  }
  // Where waypoints may go: the flight volume shrunk by r_uav / 2.
  [[nodiscard]] const Aabb& waypoint_box() const { return waypoint_box_; }
  // What every candidate's shots follow, unscored: the teammates' pending
  // shots (PlanningContext::teammates), then the shot due right at the
  // start, if any.
  [[nodiscard]] const std::vector<PoseObservation>& start_observations() const {
    return start_observations_;
  }
  // Candidates scored without the conditioned start observations
  // (InformationEvaluator::prefix_misses): 0 unless something is wrong.
  [[nodiscard]] std::int64_t prefix_misses() const { return evaluator_.prefix_misses(); }

 private:
  // (k1 O_info - k2 C_coll) / t_flight, t_flight floored at min_flight_time_s.
  [[nodiscard]] double Objective(double information, int collision_samples,
                                 double duration_s) const;
  // C_coll of `trajectory` (docs/method.md §6.2): samples every
  // 1 / collision_sample_rate_hz outside the flight volume or closer than
  // r_uav / 2 to an obstacle, by the ESDF or (exact) by the obstacles' own
  // geometry.
  [[nodiscard]] int CollisionSamples(const PolynomialTrajectory& trajectory, bool exact) const;

  PathScorer(const PlanningContext& mission, const UavState& state, const PlannerLimits& limits,
             const InformationParams& information, const ScoreWeights& weights);

  PlanningContext mission_;
  UavState state_;
  PlannerLimits limits_;
  ScoreWeights weights_;
  // The search area on the map's own cells when the map is a window of the
  // field (the evaluator reads it); empty otherwise.
  std::vector<std::uint8_t> window_area_;
  InformationEvaluator evaluator_;
  Aabb waypoint_box_;
  std::vector<PoseObservation> start_observations_;
  // How many of start_observations_ are teammates' shots (they come first).
  std::size_t teammate_observations_ = 0;
  // With teammates: their positions at the collision samples' instants.
  std::optional<SeparationSampler> separation_;
};

}  // namespace oaipp
