#include "client/cli/mission_runner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "api/geometry.h"
#include "api/measurement.h"
#include "api/mission_config.h"
#include "api/plan.h"
#include "client/cli/map_image.h"
#include "core/common/status_macros.h"
#include "core/trajectory/min_snap.h"
#include "sim/flight.h"

namespace oaipp::client {

namespace {

constexpr double kNever = std::numeric_limits<double>::infinity();
// How long a boxed-in team member hovers before it asks again.
constexpr double kHold_s = 1.0;

// One UAV of the mission: where it is on the mission clock, and the path it
// is flying.
struct Pilot {
  Pilot(const sim::Simulation& sim, std::string id, const v1::UavState& start, std::uint64_t seed)
      : uav_id(std::move(id)),
        state(start),
        rng(seed),
        flight(sim, api::FromProto(start.position_m()), uav_id) {}

  std::string uav_id;
  // The mission it flies in and its uav_id there: the team's mission and
  // uav_id, or (separate maps) its own mission and "".
  std::string mission;
  std::string mission_uav_id;
  v1::UavState state;  // at the end of the last path flown (the start before any)
  std::mt19937_64 rng;
  sim::Flight flight;
  bool done = false;  // the budget is spent, or it has flown home
  // After a path cut short at a shot: the shot after it (see RunScenario).
  std::optional<double> next_shot_s;

  // The path being flown: from state's mission time, for `fly` seconds;
  // `t` is the last step's time on it, negative before the first.
  std::optional<PolynomialTrajectory> trajectory;
  v1::PlanPathResponse path;
  double fly = 0.0;
  double t = -1.0;
  int next_shot = 0;

  // The next step's time on the path (sim::Flight::Fly's steps: every
  // kStep_s from 0, the last one at `fly` exactly).
  [[nodiscard]] double NextStep() const {
    return t < 0.0 ? 0.0 : std::min(t + sim::Flight::kStep_s, fly);
  }
  // When this UAV acts next on the mission clock: plans, or takes a step.
  [[nodiscard]] double NextEventS() const {
    if (done) return kNever;
    return state.mission_time_s() + (trajectory.has_value() ? NextStep() : 0.0);
  }
  // Where it is at mission time `s`, for s at or after its last step: on
  // its path, or where it stopped.
  [[nodiscard]] Vec3 PositionAt(double s) const {
    if (!trajectory.has_value()) return api::FromProto(state.position_m());
    return trajectory->Position(std::clamp(s - state.mission_time_s(), 0.0, fly));
  }
  // The first shot not taken yet: the path's next pose, or the one after
  // its end.
  [[nodiscard]] double FollowingShotS() const {
    return next_shot < path.measurement_poses_size()
               ? path.measurement_poses(next_shot).mission_time_s()
               : path.next_shot_mission_s();
  }
};

// Member i of `team_spec`'s team as a mission of its own: one UAV at that
// member's start with its camera, detector and limits, nothing of the team
// (separate maps).
v1::MissionSpec Alone(const v1::MissionSpec& team_spec, int i) {
  v1::MissionSpec spec = team_spec;
  const v1::TeamMember& member = team_spec.team(i);
  *spec.mutable_start() = member.start();
  // A member's noise model replaces the mission's, as it does in the team.
  if (member.sensor().has_detector_noise()) {
    spec.mutable_sensor()->clear_noise_a_var();
    spec.mutable_sensor()->clear_noise_b_per_m();
  } else if (member.sensor().has_noise_a_var() || member.sensor().has_noise_b_per_m()) {
    spec.mutable_sensor()->clear_detector_noise();
  }
  spec.mutable_sensor()->MergeFrom(member.sensor());
  spec.mutable_flight()->MergeFrom(member.flight());
  spec.clear_team();
  spec.clear_min_separation_m();
  spec.clear_count_teammate_shots();
  return spec;
}

}  // namespace

absl::StatusOr<RunResult> RunScenario(Client& client, const v1::Scenario& scenario,
                                      const sim::Simulation& sim,
                                      const std::function<void(const StepRecord&)>& progress,
                                      bool keep_mission,
                                      const std::function<void(const std::string&)>& frame) {
  RunResult result;
  result.sightings.resize(static_cast<std::size_t>(sim.num_targets()));
  const bool separate = scenario.separate_maps() && !scenario.mission().team().empty();
  // With separate maps this first mission is nobody's: it fuses every
  // member's shots, and the records are read from it.
  OAIPP_ASSIGN_OR_RETURN(
      v1::Mission mission,
      client.CreateMission(separate ? Alone(scenario.mission(), 0) : scenario.mission()));
  result.mission_name = mission.name();
  // Every mission created so far is deleted on the way out, whatever fails.
  std::vector<std::string> created = {mission.name()};
  struct Cleanup {
    Client& client;
    const std::vector<std::string>& names;
    bool keep;
    ~Cleanup() {
      if (keep) return;
      for (const std::string& name : names) (void)client.DeleteMission(name);
    }
  } cleanup{client, created, keep_mission};
  const v1::MissionSpec& spec = separate ? scenario.mission() : mission.spec();
  const double budget = mission.spec().budget_s();
  const double min_separation_m =
      spec.has_min_separation_m() ? spec.min_separation_m() : api::MissionConfig{}.min_separation_m;
  std::vector<Pilot> pilots;
  if (spec.team().empty()) {
    pilots.emplace_back(sim, "", mission.spec().start(), scenario.seed());
  } else {
    for (int i = 0; i < spec.team_size(); ++i) {
      pilots.emplace_back(sim, spec.team(i).uav_id(), spec.team(i).start(),
                          scenario.seed() + static_cast<std::uint64_t>(i));
    }
  }
  result.uavs.resize(pilots.size());
  for (std::size_t i = 0; i < pilots.size(); ++i) {
    Pilot& pilot = pilots[i];
    result.uavs[i].uav_id = pilot.uav_id;
    pilot.mission = result.mission_name;
    pilot.mission_uav_id = separate ? "" : pilot.uav_id;
    if (separate) {
      OAIPP_ASSIGN_OR_RETURN(v1::Mission own,
                             client.CreateMission(Alone(scenario.mission(), static_cast<int>(i))));
      pilot.mission = own.name();
      created.push_back(own.name());
    }
    result.uavs[i].mission = pilot.mission;
  }
  result.closest_approach_m = kNever;
  result.min_separation_m = min_separation_m;
  const double t0 = pilots.front().state.mission_time_s();  // every member's (the server checks)

  StepRecord record;
  record.mission_time_s = t0;
  std::vector<double> mean;  // the map's mean at the last record
  const auto flown_paths = [&] {
    std::vector<FlownPath> paths;
    for (const UavRecord& u : result.uavs) paths.push_back({u.uav_id, u.flown_path_W});
    return paths;
  };
  // The record after a shot (or at the start), from the mission's map; with
  // separate maps, from the map that fuses every member's shots.
  auto measure_record = [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(v1::GetMapResponse map, client.GetMap(result.mission_name, true, false));
    mean.assign(map.mean().begin(), map.mean().end());
    record.trace = map.trace();
    record.rse = sim.Rse(mean);
    record.rmse = sim.Rmse(mean);
    record.targets_found = sim.TargetsFound(mean);
    result.steps.push_back(record);
    if (progress) progress(record);
    if (frame) {
      OAIPP_ASSIGN_OR_RETURN(
          std::string png,
          RenderMissionPng(map, sim, flown_paths(), result.mission_name, record.mission_time_s));
      frame(png);
    }
    return absl::OkStatus();
  };
  const auto record_flight = [&] {
    record.path_length_m = 0.0;
    record.collisions = 0;
    for (std::size_t i = 0; i < pilots.size(); ++i) {
      UavRecord& u = result.uavs[i];
      u.path_length_m = pilots[i].flight.path_length_m();
      u.collisions = pilots[i].flight.collisions();
      u.flown_path_W = pilots[i].flight.trace_W();
      record.path_length_m += u.path_length_m;
      record.collisions += u.collisions;
    }
  };
  record_flight();
  OAIPP_RETURN_IF_ERROR(measure_record());
  // Takes one planned shot of pilot i: the detector's boxes there go to the
  // server, the metrics and each person in view are recorded. True when
  // anything was reported.
  const auto take_shot = [&](std::size_t i,
                             const v1::MeasurementPose& shot) -> absl::StatusOr<bool> {
    Pilot& pilot = pilots[i];
    const Vec3 camera = api::FromProto(shot.position_m());
    const std::vector<sim::TargetSightings> before = result.sightings;
    const std::vector<PixelBox> boxes =
        sim.Detect(camera, pilot.rng, &result.sightings, pilot.uav_id);
    api::MeasurementInput input{.mission_time_s = shot.mission_time_s(),
                                .pose = CameraPose{camera, 0.0},
                                .uav_id = pilot.uav_id};
    if (scenario.send_cell_labels()) {
      OAIPP_ASSIGN_OR_RETURN(input.labels, sim.Labels(camera, boxes, pilot.uav_id));
    } else {
      input.detections =
          api::MeasurementInput::Detections{.intrinsics = sim.intrinsics(pilot.uav_id),
                                            .boxes = boxes,
                                            .min_confidence = sim.detector().min_confidence};
    }
    v1::AddMeasurementRequest m;
    api::MeasurementToProto(input, &m);
    m.set_name(pilot.mission);
    m.set_uav_id(pilot.mission_uav_id);
    OAIPP_RETURN_IF_ERROR(client.AddMeasurement(m).status());
    if (separate) {  // and to the map of what the team knows together
      m.set_name(result.mission_name);
      OAIPP_RETURN_IF_ERROR(client.AddMeasurement(m).status());
    }
    ++result.uavs[i].shots;
    record.uav_id = pilot.uav_id;
    record.mission_time_s = shot.mission_time_s();
    // With final_map_only the map is not read here, so the sightings carry
    // no mean after the shot (NaN).
    if (!scenario.final_map_only()) {
      record_flight();
      OAIPP_RETURN_IF_ERROR(measure_record());
    }
    const std::vector<double> target_means = scenario.final_map_only()
                                                 ? std::vector<double>(before.size(), std::nan(""))
                                                 : sim.TargetMeans(mean);
    for (std::size_t k = 0; k < before.size(); ++k) {
      if (result.sightings[k].in_view == before[k].in_view) continue;
      result.sighting_log.push_back({.target = static_cast<int>(k),
                                     .mission_time_s = shot.mission_time_s(),
                                     .altitude_m = camera.z(),
                                     .detected = result.sightings[k].detected > before[k].detected,
                                     .mean_after = target_means[k]});
    }
    return std::any_of(boxes.begin(), boxes.end(), [&](const PixelBox& box) {
      return box.confidence >= sim.detector().min_confidence;
    });
  };
  // Pilot i asks for a path from where it is, or is done when its budget is
  // spent. Unset, next_shot_s lets the server take the next multiple of the
  // shot period at or after the state's time, which is the shot just taken
  // when a cut falls on its very instant (the take-off shot at t = 0): the
  // camera would fire again where it is.
  const auto plan = [&](std::size_t i) -> absl::Status {
    Pilot& pilot = pilots[i];
    if (pilot.state.mission_time_s() - t0 >= budget - 1e-9 ||
        (scenario.has_path_budget_m() &&
         pilot.flight.path_length_m() >= scenario.path_budget_m())) {
      pilot.done = true;
      return absl::OkStatus();
    }
    v1::PlanPathRequest request;
    request.set_name(pilot.mission);
    request.set_uav_id(pilot.mission_uav_id);
    *request.mutable_state() = pilot.state;
    if (pilot.next_shot_s.has_value()) request.set_next_shot_mission_s(*pilot.next_shot_s);
    if (scenario.has_planning_budget_s())
      request.set_planning_budget_s(scenario.planning_budget_s());
    const auto plan_start = std::chrono::steady_clock::now();
    absl::StatusOr<v1::PlanPathResponse> planned = client.PlanPath(request);
    const double latency_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - plan_start).count();
    result.planning_time_s += latency_s;
    result.plan_latencies_s.push_back(latency_s);
    if (absl::IsFailedPrecondition(planned.status()) && pilots.size() > 1 &&
        !pilot.next_shot_s.has_value()) {
      // Boxed in, at rest, by teammates (and obstacles): it hovers where
      // it is, as the server holds it, and asks again kHold_s later, when
      // they have moved on. Shots wait until it flies again.
      ++result.holds;
      ++result.uavs[i].holds;
      pilot.state.set_mission_time_s(pilot.state.mission_time_s() + kHold_s);
      return absl::OkStatus();
    }
    if (!planned.ok()) return planned.status();
    pilot.path = *std::move(planned);
    ++result.plans;
    ++result.uavs[i].plans;
    OAIPP_ASSIGN_OR_RETURN(pilot.trajectory, api::TrajectoryFromProto(pilot.path.trajectory()));
    pilot.fly =
        std::min(pilot.trajectory->Duration(), budget - (pilot.state.mission_time_s() - t0));
    pilot.t = -1.0;
    pilot.next_shot = 0;
    return absl::OkStatus();
  };
  // Pilot i's next step on its path, checking the exact clearance and the
  // distance to every teammate; the camera fires at the planned shots. With
  // replan_on_detection, a shot with any report ends the path there, unless
  // the path ends there anyway or no shot can follow it within the budget.
  const bool replan_on_detection = scenario.replan_on_detection();
  const auto step = [&](std::size_t i) -> absl::Status {
    Pilot& pilot = pilots[i];
    const double t = pilot.t = pilot.NextStep();
    const Vec3 here = pilot.trajectory->Position(t);
    pilot.flight.MoveTo(here);
    const double now = pilot.state.mission_time_s() + t;
    for (std::size_t j = 0; j < pilots.size(); ++j) {
      if (j == i) continue;
      const double d = (here - pilots[j].PositionAt(now)).norm();
      result.closest_approach_m = std::min(result.closest_approach_m, d);
      if (d < min_separation_m - 1e-6) ++result.separation_violations;
    }
    bool reported = false;
    const v1::PlanPathResponse& path = pilot.path;
    while (pilot.next_shot < path.measurement_poses_size() &&
           path.measurement_poses(pilot.next_shot).t_s() <= t + 1e-9) {
      OAIPP_ASSIGN_OR_RETURN(const bool any,
                             take_shot(i, path.measurement_poses(pilot.next_shot++)));
      reported |= any;
    }
    // t < fly: a report at the path's last step leaves it at its end, as
    // without the option.
    const bool cut = reported && replan_on_detection && t < pilot.fly && !path.returning_home() &&
                     pilot.FollowingShotS() < t0 + budget - 1e-9;
    if (!cut && t < pilot.fly) return absl::OkStatus();
    // The path ends here.
    const PolynomialTrajectory& traj = *pilot.trajectory;
    if (!scenario.final_map_only()) record_flight();  // else once, at the end
    v1::UavState& state = pilot.state;
    *state.mutable_position_m() = api::ToProto(traj.Position(t));
    *state.mutable_velocity_m_s() = api::ToProto(traj.Velocity(t));
    pilot.next_shot_s.reset();
    if (cut) {
      ++result.paths_cut;
      ++result.uavs[i].paths_cut;
      *state.mutable_acceleration_m_s2() = api::ToProto(traj.Acceleration(t));
      pilot.next_shot_s = pilot.FollowingShotS();
    } else if (AtRest(traj.Velocity(t), traj.Acceleration(t))) {
      state.clear_acceleration_m_s2();  // at the path's end, at rest
    } else {
      // A path cut short so that its way home fits ends moving.
      *state.mutable_acceleration_m_s2() = api::ToProto(traj.Acceleration(t));
    }
    state.set_mission_time_s(state.mission_time_s() + t);
    pilot.trajectory.reset();
    if (path.returning_home() && !cut) {
      // Home, at rest above the landing spot: the autopilot lands it.
      pilot.done = true;
      result.uavs[i].landed_with_s = path.remaining_after_return_s();
    }
    return absl::OkStatus();
  };
  // The UAV due first acts; the earlier in the team on a tie.
  for (;;) {
    std::size_t next = 0;
    for (std::size_t i = 1; i < pilots.size(); ++i) {
      if (pilots[i].NextEventS() < pilots[next].NextEventS()) next = i;
    }
    if (pilots[next].done) break;
    OAIPP_RETURN_IF_ERROR(pilots[next].trajectory.has_value() ? step(next) : plan(next));
  }
  record_flight();
  record.uav_id.clear();
  record.mission_time_s = t0;
  for (const Pilot& pilot : pilots) {
    record.mission_time_s = std::max(record.mission_time_s, pilot.state.mission_time_s());
  }
  if (result.steps.back().mission_time_s < record.mission_time_s)
    OAIPP_RETURN_IF_ERROR(measure_record());
  // The mission's map (with separate maps, the one of every shot) and every
  // UAV's flown path.
  OAIPP_ASSIGN_OR_RETURN(v1::GetMapResponse final_map,
                         client.GetMap(result.mission_name, true, false));
  OAIPP_ASSIGN_OR_RETURN(
      result.final_map_png,
      RenderMissionPng(final_map, sim, flown_paths(), result.mission_name, record.mission_time_s));
  result.found_at_end =
      sim.FoundEach(std::vector<double>(final_map.mean().begin(), final_map.mean().end()));
  if (!keep_mission) {
    for (const std::string& name : created) OAIPP_RETURN_IF_ERROR(client.DeleteMission(name));
    created.clear();
  }
  return result;
}

std::string StepsCsv(const std::vector<StepRecord>& steps) {
  const bool team = std::any_of(steps.begin(), steps.end(),
                                [](const StepRecord& s) { return !s.uav_id.empty(); });
  std::string csv = absl::StrCat(team ? "uav_id," : "",
                                 "time_s,rse,rmse,trace,targets_found,path_length_m,collisions\n");
  for (const StepRecord& s : steps) {
    if (team) absl::StrAppend(&csv, s.uav_id, ",");
    absl::StrAppendFormat(&csv, "%.3f,%.6f,%.6f,%.6f,%d,%.3f,%d\n", s.mission_time_s, s.rse, s.rmse,
                          s.trace, s.targets_found, s.path_length_m, s.collisions);
  }
  return csv;
}

}  // namespace oaipp::client
