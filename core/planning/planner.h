// The planner interface and what every planner shares (docs/method.md §5-8).
//
// A planner reads the mission (environment, field grid, GP map, camera and
// sensor models), the UAV's state and a deadline, and returns a trajectory
// with its control waypoints, measurement poses, objective value, exact
// collision verdict and statistics. Planners may keep state between calls
// (the lawnmower's place in its pattern, a random stream), so a mission
// owns its own planner object.
//
//   std::unique_ptr<Planner> planner = MakePlanner(config);  // planners.h
//   PlanningContext context{&env, &map, camera, noise};
//   OAIPP_ASSIGN_OR_RETURN(PlannedPath path, planner->Plan(view, state, absl::Now() +
//   absl::Seconds(1)));
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"
#include "core/environment/environment.h"
#include "core/mapping/camera.h"
#include "core/mapping/gp_map.h"
#include "core/planning/information.h"
#include "core/trajectory/min_snap.h"

namespace oaipp {

// One committed plan on a teammate's timeline: flown from start_mission_s
// until the next piece of the timeline starts.
struct TimelinePiece {
  PolynomialTrajectory trajectory;
  double start_mission_s = 0.0;
};

// Another UAV of the same mission, as a plan must keep clear of it
// (core/planning/separation.h, docs/teams.md "The guarantee"). Its future
// is a timeline: `earlier` pieces, by start time, each flown until the next
// one starts, then its newest plan (`trajectory`, from start_mission_s on),
// after whose end it hovers at the last point. Before the timeline's first
// start it is at that piece's first point.
// A teammate that has gone silent (or was removed without landing) may
// drift from where its timeline puts it once it should be hovering: from
// drift_from_s on (mission time) it is anywhere within
// drift_m_s * (t - drift_from_s) of that point.
// A pair may need more room than the mission's min_separation_m (their
// bodies and tracking errors, r_i + r_j + margin): min_distance_m.
// Its shots still to come (pending_shots_W, where the camera will be) count
// in a plan's objective as if already taken, so that a UAV does not plan to
// look again at ground a teammate is about to see; each sees the teammate's
// own camera footprint with its own noise (unset: the planning UAV's).
struct Teammate {
  std::string uav_id;  // names it in messages
  PolynomialTrajectory trajectory;
  double start_mission_s = 0.0;
  std::vector<TimelinePiece> earlier = {};
  double min_distance_m = 0.0;
  double drift_from_s = std::numeric_limits<double>::infinity();
  double drift_m_s = 0.0;
  std::vector<Vec3> pending_shots_W = {};
  std::optional<DownwardCamera> camera = std::nullopt;
  std::optional<SensorNoise> noise = std::nullopt;
};

// What a planner reads of its mission for one plan: the world, the map, the
// sensor and the mission's clock. The pointers must outlive the Plan call.
struct PlanningContext {
  const Environment* environment = nullptr;
  const GpMap* map = nullptr;
  DownwardCamera camera;  // footprint and shot rate
  SensorNoise noise;
  // When the camera fires next (mission clock, seconds): the sensor phase
  // carries over across replans (docs/method.md §4). Valid: >= the state's
  // mission_time_s.
  double next_shot_mission_s = 0.0;
  // Flight time left in the mission's budget, seconds. Valid: > 0.
  double remaining_budget_s = std::numeric_limits<double>::infinity();
  // Asked now and then while planning; true abandons the plan with
  // Cancelled (e.g. the caller went away). May be empty.
  std::function<bool()> cancelled = nullptr;
  // The share of its configured search the planner runs, in (0, 1]: OA-IPP
  // runs ceil(fraction x generations) CMA-ES generations (at least one).
  // Below 1 only when a loaded server sheds work (docs/capacity.md); the
  // other planners ignore it.
  double search_fraction = 1.0;
  // Covariances of `map` conditioned on a plan's first shot, shared with
  // other plans over the same map (nullptr: each plan conditions its own).
  // The caller promises that the map does not change while the cache is used
  // with it, and that the cache serves no other covariance.
  ConditionedCache* conditioned = nullptr;
  // A team mission's chain of conditioned covariances (docs/teams.md),
  // with the caller's name for `map`'s current covariance; when set, the
  // plan's conditioning comes from it and `conditioned` is not read.
  ChainedPrefix chain = {};
  // The mission's other UAVs, and how far apart any two must stay
  // (centre to centre, metres; valid: > 0, finite). With no teammates
  // (the default) a plan is exactly what it would be without these fields.
  std::span<const Teammate> teammates = {};
  double min_separation_m = 4.0;
  // The whole field when `map` is a window of it (a large field,
  // docs/method.md §3.10): the lawnmower's pattern and the random planner's
  // destinations cover it. nullptr: map's own grid.
  const FieldGrid* field = nullptr;
  // The mission's search area over the field (`field`, else map's grid):
  // one byte per cell, nonzero where the ground is to be searched; empty:
  // all of it. A cell outside earns nothing (InformationEvaluator's
  // `area`); the random planner draws its destinations inside. Must
  // outlive the plan, as the map must.
  std::span<const std::uint8_t> search_area = {};
};

// The UAV when planning starts: its kinematic state on the mission clock.
struct UavState {
  Vec3 position_W = Vec3::Zero();
  Vec3 velocity_W_m_s = Vec3::Zero();
  Vec3 accel_W_m_s2 = Vec3::Zero();
  // Mission clock, seconds since the mission started.
  double mission_time_s = 0.0;
};

// The UAV t_s into `trajectory`, which it began at start_mission_time_s
// (t_s is clamped to the trajectory, as Position does): where the next plan
// starts when this one is flown to t_s.
[[nodiscard]] inline UavState StateAlong(const PolynomialTrajectory& trajectory, double t_s,
                                         double start_mission_time_s) {
  return {.position_W = trajectory.Position(t_s),
          .velocity_W_m_s = trajectory.Velocity(t_s),
          .accel_W_m_s2 = trajectory.Acceleration(t_s),
          .mission_time_s = start_mission_time_s + t_s};
}

// Settings shared by every planner; defaults from docs/method.md.
struct PlannerLimits {
  TrajectoryLimits dynamics;  // 5 m/s, 3 m/s^2
  // Radius of the smallest sphere holding the UAV, metres, valid: > 0. A
  // pose collides when it is closer to an obstacle than ObstacleClearance().
  double uav_radius_m = 1.0;
  // How far the UAV may stray from its trajectory while its controller
  // tracks it, metres; widens the distance two UAVs keep (docs/teams.md).
  // Valid: [0, 10].
  double tracking_error_m = 0.5;
  // Samples per second for the collision cost C_coll (Eq. 3). Valid: > 0.
  double collision_sample_rate_hz = 20.0;
  // Spacing of the final exact collision check along the path, metres.
  double exact_check_spacing_m = 0.1;
  // How far a path keeps from obstacles (docs/method.md §2, "Clearance").
  // kBody: the UAV's sphere and how far it strays, uav_radius_m +
  // tracking_error_m (the service's default). kPaperHalfRadius: the paper's
  // rule (Eq. 2), uav_radius_m / 2, which the "paper" preset asks for so
  // that E1-E5 reproduce the paper; the core's default.
  enum class ObstacleRule { kPaperHalfRadius, kBody };
  ObstacleRule obstacle_rule = ObstacleRule::kPaperHalfRadius;

  [[nodiscard]] double ObstacleClearance() const {
    return obstacle_rule == ObstacleRule::kBody ? uav_radius_m + tracking_error_m
                                                : 0.5 * uav_radius_m;
  }
  [[nodiscard]] absl::Status Validate() const;
};

// The rule `limits` keeps from obstacles, as errors name it.
[[nodiscard]] inline const char* ClearanceRuleName(const PlannerLimits& limits) {
  return limits.obstacle_rule == PlannerLimits::ObstacleRule::kBody
             ? "uav_radius_m + tracking_error_m"
             : "uav_radius_m / 2";
}

// A measurement the camera will take along the path.
struct MeasurementPose {
  double t_s = 0.0;             // since the trajectory start
  double mission_time_s = 0.0;  // on the mission clock
  Vec3 position_W = Vec3::Zero();
};

struct PlannerStats {
  std::int64_t evaluations = 0;  // objective evaluations, greedy included
  int generations = 0;           // CMA-ES generations
  double wall_time_s = 0.0;
  std::string stop_reason = {};    // e.g. "evaluation_budget", "deadline", "pattern"
  double initial_objective = 0.0;  // the greedy start's score (OA-IPP)
  // Seconds spent braking to rest before the planned part (0: planned from
  // the UAV's state directly; core/planning/stop_first.h).
  double stop_first_s = 0.0;
  // PlanningContext::search_fraction as this plan ran it.
  double search_fraction = 1.0;
  // Seconds from the call's arrival until a planner took it up (set by the
  // server; 0 in-process).
  double queued_s = 0.0;
  // Seconds the search was allowed (set by the server, 0 in-process;
  // PlannerStats.search_budget_s in the proto says which budget).
  double search_budget_s = 0.0;
};

struct PlannedPath {
  PolynomialTrajectory trajectory;
  std::vector<Vec3> control_waypoints_W = {};  // c1 (the UAV's position) .. cN
  std::vector<MeasurementPose> measurement_poses = {};
  double objective = 0.0;            // (k1 O_info - k2 C_coll) / t_flight
  double information = 0.0;          // O_info
  int collision_samples = 0;         // C_coll by the exact distance (PathScorer::Finish)
  bool collision_free = false;       // the exact check; always true for a returned path
  double next_shot_mission_s = 0.0;  // sensor phase after the path
  PlannerStats stats = {};
  // Set by the service that keeps a team's trajectories, not by a planner
  // (empty for one UAV): whose path this is, its version, when on the
  // mission clock it starts, and the teammates' versions (uav_id, version)
  // it keeps clear of.
  struct TeamStamp {
    std::string uav_id;
    std::int64_t plan_version = 0;
    double start_mission_s = 0.0;
    std::vector<std::pair<std::string, std::int64_t>> checked_against;
    // Of those teammates, how many of each one's shots still to come the
    // plan counted as taken (absent: none).
    std::map<std::string, int> shots_counted = {};
  };
  TeamStamp team = {};
  // Set where the mission has a home (core/planning/return_home.h): the way
  // home from this path's end, and the flight seconds left after this path,
  // that way home and the landing; or, when returning_home, this path is the
  // way home and remaining_after_return_s what is left once landed.
  std::optional<PolynomialTrajectory> way_home = std::nullopt;
  std::optional<double> remaining_after_return_s = std::nullopt;
  bool returning_home = false;
};

class Planner {
 public:
  virtual ~Planner() = default;
  [[nodiscard]] virtual absl::string_view name() const = 0;
  // Plans from `state`. Returns InvalidArgument for bad input (non-finite
  // state, start outside the volume or inside an obstacle, empty field, no
  // budget left),
  // DeadlineExceeded when the deadline passed before any safe path was
  // found, Cancelled when mission.cancelled() said so, and FailedPrecondition when no
  // collision-free path exists among those tried. A returned path is always collision-free under
  // the exact check.
  [[nodiscard]] virtual absl::StatusOr<PlannedPath> Plan(const PlanningContext& mission,
                                                         const UavState& state,
                                                         absl::Time deadline) = 0;

  // What the planner carries from one plan to the next (the lawnmower's
  // place in its pattern), as text that RestoreState takes back, so that a
  // mission reloaded from storage plans as it would have. Empty for a
  // planner that keeps nothing.
  [[nodiscard]] virtual std::string SaveState() const { return {}; }
  // InvalidArgument when `state` is not one SaveState of this kind gives.
  [[nodiscard]] virtual absl::Status RestoreState(absl::string_view state) {
    if (state.empty()) return absl::OkStatus();
    return absl::InvalidArgumentError(absl::StrCat("planner state: ", name(), " keeps no state"));
  }
};

// A planner around another (StopFirstPlanner, ReturnHomePlanner): its name
// and what it carries from plan to plan are the inner planner's.
class WrappingPlanner : public Planner {
 public:
  explicit WrappingPlanner(std::unique_ptr<Planner> inner) : inner_(std::move(inner)) {}
  [[nodiscard]] absl::string_view name() const override { return inner_->name(); }
  [[nodiscard]] std::string SaveState() const override { return inner_->SaveState(); }
  [[nodiscard]] absl::Status RestoreState(absl::string_view state) override {
    return inner_->RestoreState(state);
  }

 protected:
  [[nodiscard]] Planner& inner() { return *inner_; }

 private:
  std::unique_ptr<Planner> inner_;
};

}  // namespace oaipp
