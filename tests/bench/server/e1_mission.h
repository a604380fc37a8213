// The E1 benchmark mission (DESIGN.md §4) as an API spec and its ground
// truth, for the service benchmarks.
#pragma once

#include <vector>

#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::bench {

// Paper preset, 30 x 30 m field, the 4 x 10 x 26 m building, start (10, 0, 7).
inline v1::MissionSpec E1Spec(int generations = 45) {
  v1::MissionSpec spec;
  spec.set_preset("paper");
  spec.mutable_planner()->set_generations(generations);
  v1::Obstacle* b = spec.add_obstacles();
  b->set_id("building");
  b->mutable_box()->mutable_centre_m()->set_y(-1);
  b->mutable_box()->mutable_centre_m()->set_z(13);
  b->mutable_box()->mutable_size_m()->set_x(10);
  b->mutable_box()->mutable_size_m()->set_y(4);
  b->mutable_box()->mutable_size_m()->set_z(26);
  spec.mutable_start()->mutable_position_m()->set_x(10);
  spec.mutable_start()->mutable_position_m()->set_z(7);
  return spec;
}

// 1 on the 48 cells the seven E1 people cover, 0 elsewhere (40 x 40 grid).
inline std::vector<double> E1Truth() {
  std::vector<double> truth(1600, 0.0);
  const double people[7][2] = {{8, -12}, {-6, -7},  {12, -7}, {-7, -12},
                               {4, -11}, {-12, -6}, {0, -7}};
  for (const auto& p : people) {
    for (int row = 0; row < 40; ++row) {
      for (int col = 0; col < 40; ++col) {
        const double x0 = -15 + 0.75 * col, y0 = -15 + 0.75 * row;
        const bool overlap =
            x0 < p[0] + 0.375 && x0 + 0.75 > p[0] - 0.375 && y0 < p[1] + 2 && y0 + 0.75 > p[1];
        if (overlap) truth[row * 40 + col] = 1.0;
      }
    }
  }
  return truth;
}

// Labels of the 40 x 40 cells whose centres lie under a camera at p (FoV
// 45 x 60 deg), from the ground truth. (Occlusion is ignored: this feeds
// the server realistic load, not a faithful simulation.)
inline v1::AddMeasurementRequest E1Measurement(const std::string& name, const v1::Vector3& p,
                                               double time_s, const std::vector<double>& truth) {
  v1::AddMeasurementRequest request;
  request.set_name(name);
  request.set_mission_time_s(time_s);
  *request.mutable_camera_position_m() = p;
  const double hx = p.z() * 0.41421356, hy = p.z() * 0.57735027;  // tan 22.5, tan 30
  for (int row = 0; row < 40; ++row) {
    for (int col = 0; col < 40; ++col) {
      const double x = -15 + 0.75 * (col + 0.5), y = -15 + 0.75 * (row + 0.5);
      if (std::abs(x - p.x()) <= hx && std::abs(y - p.y()) <= hy) {
        request.mutable_labels()->add_cells(row * 40 + col);
        request.mutable_labels()->add_labels(truth[row * 40 + col]);
      }
    }
  }
  return request;
}

}  // namespace oaipp::bench
