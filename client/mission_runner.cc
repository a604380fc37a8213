#include "client/mission_runner.h"

#include <chrono>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/map_image.h"
#include "core/common/status_macros.h"
#include "server/convert.h"

namespace oaipp::client {
namespace {

// Position and velocity on a returned trajectory at t (clamped), from its
// polynomial segments (lowest order first, time since the segment start).
void Evaluate(const v1::Trajectory& traj, double t, Vec3* p, Vec3* v) {
  double start = 0.0;
  int s = 0;
  while (s + 1 < traj.segments_size() && t > start + traj.segments(s).duration_s()) {
    start += traj.segments(s).duration_s();
    ++s;
  }
  const v1::PolynomialSegment& seg = traj.segments(s);
  const double tau = std::clamp(t - start, 0.0, seg.duration_s());
  auto poly = [&](const google::protobuf::RepeatedField<double>& c, double* value, double* rate) {
    *value = 0.0;
    *rate = 0.0;
    for (int k = c.size() - 1; k >= 0; --k) {
      *rate = *rate * tau + *value;
      *value = *value * tau + c[k];
    }
  };
  double dx, dy, dz;
  poly(seg.x_coefficients(), &p->x(), &dx);
  poly(seg.y_coefficients(), &p->y(), &dy);
  poly(seg.z_coefficients(), &p->z(), &dz);
  *v = Vec3(dx, dy, dz);
}

}  // namespace

absl::StatusOr<RunResult> RunScenario(Client& client, const v1::Scenario& scenario,
                                      const Simulation& sim,
                                      const std::function<void(const StepRecord&)>& progress,
                                      bool keep_mission,
                                      const std::function<void(const std::string&)>& frame) {
  RunResult result;
  OAIPP_ASSIGN_OR_RETURN(v1::Mission mission, client.CreateMission(scenario.mission()));
  result.mission_name = mission.name();
  const double budget = mission.spec().budget_s();
  v1::UavState state = mission.spec().start();
  const double t0 = state.mission_time_s();
  std::mt19937_64 rng(scenario.seed());
  StepRecord record;
  record.mission_time_s = t0;
  auto measure_record = [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(v1::GetMapResponse map, client.GetMap(result.mission_name, true, false));
    const std::vector<double> mean(map.mean().begin(), map.mean().end());
    record.trace = map.trace();
    record.rse = sim.Rse(mean);
    record.rmse = sim.Rmse(mean);
    record.targets_found = sim.TargetsFound(mean);
    result.steps.push_back(record);
    if (progress) progress(record);
    if (frame) {
      OAIPP_ASSIGN_OR_RETURN(std::string png, RenderMissionPng(map, sim, result.flown_path_W));
      frame(png);
    }
    return absl::OkStatus();
  };
  Vec3 previous = server::FromProto(state.position_m());
  result.flown_path_W.push_back(previous);
  OAIPP_RETURN_IF_ERROR(measure_record());
  while (state.mission_time_s() - t0 < budget - 1e-9) {
    v1::PlanPathRequest request;
    request.set_name(result.mission_name);
    *request.mutable_state() = state;
    if (scenario.has_planning_budget_s())
      request.set_planning_budget_s(scenario.planning_budget_s());
    const auto plan_start = std::chrono::steady_clock::now();
    OAIPP_ASSIGN_OR_RETURN(v1::PlanPathResponse path, client.PlanPath(request));
    result.planning_time_s +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - plan_start).count();
    ++result.plans;
    const v1::Trajectory& traj = path.trajectory();
    const double fly = std::min(traj.duration_s(), budget - (state.mission_time_s() - t0));
    // Fly: exact collision check every 20 ms of flight (<= 0.1 m at 5 m/s).
    int next_shot = 0;
    for (double t = 0.0;; t = std::min(t + 0.02, fly)) {
      Vec3 p, v;
      Evaluate(traj, t, &p, &v);
      record.path_length_m += (p - previous).norm();
      previous = p;
      if (sim.Collides(p)) ++record.collisions;
      if (result.flown_path_W.empty() || (p - result.flown_path_W.back()).norm() > 0.5) {
        result.flown_path_W.push_back(p);
      }
      // The camera fires at the planned shots.
      while (next_shot < path.measurement_poses_size() &&
             path.measurement_poses(next_shot).t_s() <= t + 1e-9) {
        const v1::MeasurementPose& shot = path.measurement_poses(next_shot++);
        const Vec3 camera = server::FromProto(shot.position_m());
        const std::vector<PixelBox> boxes = sim.Detect(camera, rng);
        v1::AddMeasurementRequest m;
        m.set_name(result.mission_name);
        m.set_mission_time_s(shot.mission_time_s());
        *m.mutable_camera_position_m() = shot.position_m();
        if (scenario.send_cell_labels()) {
          OAIPP_ASSIGN_OR_RETURN(CellLabels labels, sim.Labels(camera, boxes));
          for (std::size_t i = 0; i < labels.cells.size(); ++i) {
            m.mutable_labels()->add_cells(labels.cells[i]);
            m.mutable_labels()->add_labels(labels.labels[i]);
          }
        } else {
          v1::ImageDetections* d = m.mutable_detections();
          const CameraIntrinsics& k = sim.intrinsics();
          d->mutable_intrinsics()->set_fx_px(k.fx_px);
          d->mutable_intrinsics()->set_fy_px(k.fy_px);
          d->mutable_intrinsics()->set_cx_px(k.cx_px);
          d->mutable_intrinsics()->set_cy_px(k.cy_px);
          d->mutable_intrinsics()->set_width_px(k.width_px);
          d->mutable_intrinsics()->set_height_px(k.height_px);
          d->set_min_confidence(sim.detector().min_confidence);
          for (const PixelBox& b : boxes) {
            v1::PixelBox* out = d->add_boxes();
            out->set_x_min_px(b.x_min_px);
            out->set_y_min_px(b.y_min_px);
            out->set_x_max_px(b.x_max_px);
            out->set_y_max_px(b.y_max_px);
            out->set_confidence(b.confidence);
          }
        }
        OAIPP_RETURN_IF_ERROR(client.AddMeasurement(m).status());
        record.mission_time_s = shot.mission_time_s();
        OAIPP_RETURN_IF_ERROR(measure_record());
      }
      if (t >= fly) break;
    }
    Vec3 p, v;
    Evaluate(traj, fly, &p, &v);
    *state.mutable_position_m() = server::ToProto(p);
    *state.mutable_velocity_m_s() = server::ToProto(v);
    state.clear_acceleration_m_s2();  // replans happen at the path's end, at rest
    state.set_mission_time_s(state.mission_time_s() + fly);
  }
  record.mission_time_s = state.mission_time_s();
  if (result.steps.back().mission_time_s < record.mission_time_s)
    OAIPP_RETURN_IF_ERROR(measure_record());
  OAIPP_ASSIGN_OR_RETURN(v1::GetMapResponse final_map,
                         client.GetMap(result.mission_name, true, false));
  OAIPP_ASSIGN_OR_RETURN(result.final_map_png,
                         RenderMissionPng(final_map, sim, result.flown_path_W));
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
