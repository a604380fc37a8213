// Labelled shots over the small field (SmallSpec) for tests that check a
// mission's map against a dense Kalman filter run in the test: the shots
// sent through the service, and the same shots fused into the test's map.
#pragma once

#include <cmath>
#include <span>
#include <string>
#include <vector>

#include "core/mapping/camera.h"
#include "core/mapping/gp_map.h"
#include "gtest/gtest.h"
#include "tests/server/service_fixture.h"

namespace oaipp::server::testing {

// A camera at (x, y, altitude z) labelling the 3 x 3 cells under it
// (LabelMeasurement) with `label`.
struct LabelShot {
  double x, y, z, label;
};

// Sends `shots` to mission `name` as AddMeasurement calls 1 s apart from
// mission time 1 s; each must fuse its 9 cells.
inline void AddLabelShots(v1::MissionService::Stub& stub, const std::string& name,
                          std::span<const LabelShot> shots) {
  double time_s = 1.0;
  for (const LabelShot& s : shots) {
    grpc::ClientContext context;
    v1::AddMeasurementResponse response;
    const grpc::Status status = stub.AddMeasurement(
        &context, LabelMeasurement(name, s.x, s.y, s.z, time_s, s.label), &response);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_EQ(response.cells_fused(), 9);
    EXPECT_LE(response.trace_measurements_fused(), response.measurements_fused());
    time_s += 1.0;
  }
}

// What a small-field mission does to its map, done to `map` here: the
// ground under building b1 (x in [-1, 1], y in [-4, 0], 20 m tall) fused as
// near-certain zeros, then each shot's labels with `noise`.
inline void FuseAsTheSmallMissionWould(GpMap& map, const SensorNoise& noise,
                                       std::span<const LabelShot> shots) {
  const std::vector<int> under = map.grid().CellsUnderObstacles([](const Vec3& p) {
    return std::abs(p.x()) < 1.0 && p.y() > -4.0 && p.y() < 0.0 && p.z() < 20.0;
  });
  EXPECT_FALSE(under.empty());
  EXPECT_TRUE(map.FuseNearCertainZeros(under).ok());
  for (const LabelShot& s : shots) {
    const v1::AddMeasurementRequest request = LabelMeasurement("", s.x, s.y, s.z, 0, s.label);
    const std::vector<int> cells(request.labels().cells().begin(), request.labels().cells().end());
    const std::vector<double> labels(request.labels().labels().begin(),
                                     request.labels().labels().end());
    absl::StatusOr<std::vector<CellObservation>> observations =
        LabelsToObservations(map.grid(), noise, s.z, cells, labels);
    EXPECT_TRUE(observations.ok()) << observations.status();
    EXPECT_TRUE(map.Update(*observations).ok());
  }
}

}  // namespace oaipp::server::testing
