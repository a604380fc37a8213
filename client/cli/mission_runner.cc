#include "client/cli/mission_runner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "api/geometry.h"
#include "api/measurement.h"
#include "api/plan.h"
#include "client/cli/map_image.h"
#include "core/common/status_macros.h"
#include "sim/flight.h"

namespace oaipp::client {

absl::StatusOr<RunResult> RunScenario(Client& client, const v1::Scenario& scenario,
                                      const sim::Simulation& sim,
                                      const std::function<void(const StepRecord&)>& progress,
                                      bool keep_mission,
                                      const std::function<void(const std::string&)>& frame) {
  RunResult result;
  result.sightings.resize(static_cast<std::size_t>(sim.num_targets()));
  OAIPP_ASSIGN_OR_RETURN(v1::Mission mission, client.CreateMission(scenario.mission()));
  result.mission_name = mission.name();
  const double budget = mission.spec().budget_s();
  v1::UavState state = mission.spec().start();
  const double t0 = state.mission_time_s();
  std::mt19937_64 rng(scenario.seed());
  StepRecord record;
  record.mission_time_s = t0;
  std::vector<double> mean;  // the map's mean at the last record
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
      OAIPP_ASSIGN_OR_RETURN(std::string png,
                             RenderMissionPng(map, sim, result.flown_path_W, result.mission_name,
                                              record.mission_time_s));
      frame(png);
    }
    return absl::OkStatus();
  };
  sim::Flight flight(sim, api::FromProto(state.position_m()));
  const auto record_flight = [&] {
    record.path_length_m = flight.path_length_m();
    record.collisions = flight.collisions();
    result.flown_path_W = flight.trace_W();
  };
  record_flight();
  OAIPP_RETURN_IF_ERROR(measure_record());
  // Takes one planned shot: the detector's boxes there go to the server, the
  // metrics and each person in view are recorded. True when anything was
  // reported.
  const auto take_shot = [&](const v1::MeasurementPose& shot) -> absl::StatusOr<bool> {
    const Vec3 camera = api::FromProto(shot.position_m());
    const std::vector<sim::TargetSightings> before = result.sightings;
    const std::vector<PixelBox> boxes = sim.Detect(camera, rng, &result.sightings);
    api::MeasurementInput input{.mission_time_s = shot.mission_time_s(),
                                .pose = CameraPose{camera, 0.0}};
    if (scenario.send_cell_labels()) {
      OAIPP_ASSIGN_OR_RETURN(input.labels, sim.Labels(camera, boxes));
    } else {
      input.detections =
          api::MeasurementInput::Detections{.intrinsics = sim.intrinsics(),
                                            .boxes = boxes,
                                            .min_confidence = sim.detector().min_confidence};
    }
    v1::AddMeasurementRequest m;
    m.set_name(result.mission_name);
    api::MeasurementToProto(input, &m);
    OAIPP_RETURN_IF_ERROR(client.AddMeasurement(m).status());
    record.mission_time_s = shot.mission_time_s();
    record_flight();
    OAIPP_RETURN_IF_ERROR(measure_record());
    const std::vector<double> target_means = sim.TargetMeans(mean);
    for (std::size_t i = 0; i < before.size(); ++i) {
      if (result.sightings[i].in_view == before[i].in_view) continue;
      result.sighting_log.push_back({.target = static_cast<int>(i),
                                     .mission_time_s = shot.mission_time_s(),
                                     .altitude_m = camera.z(),
                                     .detected = result.sightings[i].detected > before[i].detected,
                                     .mean_after = target_means[i]});
    }
    return std::any_of(boxes.begin(), boxes.end(), [&](const PixelBox& box) {
      return box.confidence >= sim.detector().min_confidence;
    });
  };
  // After a path cut short at a shot: the shot after it. Unset, the server
  // takes the next multiple of the shot period at or after the state's time,
  // which is the shot just taken when the cut falls on its very instant (the
  // take-off shot at t = 0): the camera would fire again where it is.
  const bool replan_on_detection = scenario.replan_on_detection();
  std::optional<double> next_shot_s;
  while (state.mission_time_s() - t0 < budget - 1e-9) {
    v1::PlanPathRequest request;
    request.set_name(result.mission_name);
    *request.mutable_state() = state;
    if (next_shot_s.has_value()) request.set_next_shot_mission_s(*next_shot_s);
    if (scenario.has_planning_budget_s())
      request.set_planning_budget_s(scenario.planning_budget_s());
    const auto plan_start = std::chrono::steady_clock::now();
    OAIPP_ASSIGN_OR_RETURN(v1::PlanPathResponse path, client.PlanPath(request));
    result.planning_time_s +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - plan_start).count();
    ++result.plans;
    OAIPP_ASSIGN_OR_RETURN(const PolynomialTrajectory traj,
                           api::TrajectoryFromProto(path.trajectory()));
    const double fly = std::min(traj.Duration(), budget - (state.mission_time_s() - t0));
    // Fly, checking the exact clearance every step; the camera fires at the
    // planned shots. With replan_on_detection, a shot with any report ends
    // the path there, unless the path ends there anyway or no shot can
    // follow it within the budget.
    int next_shot = 0;
    // The first shot not taken yet: the path's next pose, or the one after
    // its end.
    const auto following_shot_s = [&] {
      return next_shot < path.measurement_poses_size()
                 ? path.measurement_poses(next_shot).mission_time_s()
                 : path.next_shot_mission_s();
    };
    bool cut = false;
    OAIPP_ASSIGN_OR_RETURN(
        const double flown, flight.Fly(traj, fly, [&](double t) -> absl::StatusOr<bool> {
          bool reported = false;
          while (next_shot < path.measurement_poses_size() &&
                 path.measurement_poses(next_shot).t_s() <= t + 1e-9) {
            OAIPP_ASSIGN_OR_RETURN(const bool any, take_shot(path.measurement_poses(next_shot++)));
            reported |= any;
          }
          // t < fly: a report at the path's last step leaves it at its end,
          // as without the option (Fly ends there at fly exactly).
          cut =
              reported && replan_on_detection && t < fly && following_shot_s() < t0 + budget - 1e-9;
          return !cut;
        }));
    record_flight();
    *state.mutable_position_m() = api::ToProto(traj.Position(flown));
    *state.mutable_velocity_m_s() = api::ToProto(traj.Velocity(flown));
    next_shot_s.reset();
    if (cut) {
      ++result.paths_cut;
      *state.mutable_acceleration_m_s2() = api::ToProto(traj.Acceleration(flown));
      next_shot_s = following_shot_s();
    } else {
      state.clear_acceleration_m_s2();  // at the path's end, at rest
    }
    state.set_mission_time_s(state.mission_time_s() + flown);
  }
  record.mission_time_s = state.mission_time_s();
  if (result.steps.back().mission_time_s < record.mission_time_s)
    OAIPP_RETURN_IF_ERROR(measure_record());
  OAIPP_ASSIGN_OR_RETURN(v1::GetMapResponse final_map,
                         client.GetMap(result.mission_name, true, false));
  OAIPP_ASSIGN_OR_RETURN(result.final_map_png,
                         RenderMissionPng(final_map, sim, result.flown_path_W, result.mission_name,
                                          record.mission_time_s));
  result.found_at_end =
      sim.FoundEach(std::vector<double>(final_map.mean().begin(), final_map.mean().end()));
  if (!keep_mission) OAIPP_RETURN_IF_ERROR(client.DeleteMission(result.mission_name));
  return result;
}

std::string StepsCsv(const std::vector<StepRecord>& steps) {
  std::string csv = "time_s,rse,rmse,trace,targets_found,path_length_m,collisions\n";
  for (const StepRecord& s : steps) {
    absl::StrAppendFormat(&csv, "%.3f,%.6f,%.6f,%.6f,%d,%.3f,%d\n", s.mission_time_s, s.rse, s.rmse,
                          s.trace, s.targets_found, s.path_length_m, s.collisions);
  }
  return csv;
}

}  // namespace oaipp::client
