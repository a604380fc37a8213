// An in-process MissionService for tests: the real server (Server::Start)
// with no network, real registry, planning pool and service.
#pragma once

#include <cstdlib>
#include <memory>
#include <string>
#include <thread>

#include "grpcpp/grpcpp.h"
#include "gtest/gtest.h"
#include "oaipp/v1/mission_service.grpc.pb.h"
#include "server/server.h"
#include "server/service.h"

namespace oaipp::server::testing {

class InProcessService {
 public:
  // A server assembled by Server::Start from `parts`, serving only in
  // process (no port, no metrics endpoint, no web view). Recovery from the
  // parts' store has run when this returns: recovered() says how it went.
  explicit InProcessService(ServerParts parts) {
    ServerOptions options;
    options.listen = "";
    options.metrics_listen = "";
    absl::StatusOr<std::unique_ptr<Server>> started = Server::Start(options, std::move(parts));
    // A fixture whose start failed fails the test that made it.
    if (!started.ok()) {
      ADD_FAILURE() << "Server::Start: " << started.status();
      std::abort();
    }
    server_ = *std::move(started);
    stub_ = v1::MissionService::NewStub(server_->InProcessChannel());
  }
  // The same from the parts most tests set.
  explicit InProcessService(RegistryLimits limits = {.max_missions = 64,
                                                     .max_cells_per_mission = 1600},
                            int planning_threads = 2, int planning_queue = 64,
                            MissionStore* store = nullptr, const Authenticator* auth = nullptr,
                            ServiceLimits service_limits = {})
      : InProcessService(ServerParts{.registry = limits,
                                     .service = service_limits,
                                     .planning_threads = planning_threads,
                                     .planning_queue = planning_queue,
                                     .store = store,
                                     .auth = auth}) {}
  ~InProcessService() { server_->Shutdown(absl::Seconds(5)); }

  v1::MissionService::Stub& stub() { return *stub_; }
  // Another channel to the server, in process.
  std::shared_ptr<grpc::Channel> channel() { return server_->InProcessChannel(); }
  MissionRegistry& registry() { return server_->registry(); }
  MissionServiceImpl& service() { return server_->service(); }
  PlanningPool& planners() { return server_->planners(); }
  // How many missions the start recovered from the store.
  [[nodiscard]] const absl::StatusOr<int>& recovered() const { return server_->recovered(); }

 private:
  std::unique_ptr<Server> server_;
  std::unique_ptr<v1::MissionService::Stub> stub_;
};

// A small, quick mission: 15 x 15 m field at 0.75 m (400 cells), one
// building, a short CMA-ES.
//
//   y ^     +---+        building "b1": x in [-1, 1], y in [-4, 0], 20 m tall
//     |     | b1|
//     |  S  +---+        start S = (-4, 4, 8)
//     +------------> x
inline v1::MissionSpec SmallSpec() {
  v1::MissionSpec spec;
  spec.set_preset("paper");
  spec.mutable_field()->set_x_min_m(-7.5);
  spec.mutable_field()->set_y_min_m(-7.5);
  spec.mutable_field()->set_x_max_m(7.5);
  spec.mutable_field()->set_y_max_m(7.5);
  spec.mutable_planner()->set_generations(2);
  spec.mutable_planner()->set_seed(5);
  v1::Obstacle* b = spec.add_obstacles();
  b->set_id("b1");
  b->mutable_box()->mutable_centre_m()->set_x(0);
  b->mutable_box()->mutable_centre_m()->set_y(-2);
  b->mutable_box()->mutable_centre_m()->set_z(10);
  b->mutable_box()->mutable_size_m()->set_x(2);
  b->mutable_box()->mutable_size_m()->set_y(4);
  b->mutable_box()->mutable_size_m()->set_z(20);
  spec.mutable_start()->mutable_position_m()->set_x(-4);
  spec.mutable_start()->mutable_position_m()->set_y(4);
  spec.mutable_start()->mutable_position_m()->set_z(8);
  spec.set_budget_s(60);
  return spec;
}

// CreateMission of `id` with `spec`; the mission into `out` when given.
inline grpc::Status CreateWithSpec(v1::MissionService::Stub& stub, const std::string& id,
                                   const v1::MissionSpec& spec, v1::Mission* out = nullptr) {
  grpc::ClientContext context;
  v1::CreateMissionRequest request;
  request.set_mission_id(id);
  *request.mutable_spec() = spec;
  v1::Mission mission;
  return stub.CreateMission(&context, request, out != nullptr ? out : &mission);
}

inline v1::Mission CreateSmall(v1::MissionService::Stub& stub, const std::string& id) {
  v1::Mission mission;
  const grpc::Status status = CreateWithSpec(stub, id, SmallSpec(), &mission);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return mission;
}

// A mission whose plans run until their deadline, budget or cancellation
// stops them (100,000 CMA-ES generations).
inline void CreateEndless(v1::MissionService::Stub& stub, const std::string& id) {
  grpc::ClientContext context;
  v1::CreateMissionRequest create;
  create.set_mission_id(id);
  *create.mutable_spec() = SmallSpec();
  create.mutable_spec()->mutable_planner()->set_generations(100000);
  v1::Mission mission;
  const grpc::Status status = stub.CreateMission(&context, create, &mission);
  ASSERT_TRUE(status.ok()) << status.error_message();
}

// A plan of mission `id` from its start corner; budget_s > 0 sets
// planning_budget_s.
inline v1::PlanPathRequest PlanFromCorner(const std::string& id, double budget_s = 0) {
  v1::PlanPathRequest request;
  request.set_name("missions/" + id);
  request.mutable_state()->mutable_position_m()->set_x(-4);
  request.mutable_state()->mutable_position_m()->set_y(4);
  request.mutable_state()->mutable_position_m()->set_z(8);
  if (budget_s > 0) request.set_planning_budget_s(budget_s);
  return request;
}

// Waits (up to 10 s) until `done` holds; false if it never did.
template <typename Predicate>
bool Eventually(Predicate done) {
  for (int i = 0; i < 200; ++i) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return done();
}

// Adds to `request` one detection: a 120 x 120 px box at the centre of the
// default 480 x 640 image, about 2 x 2 m on the ground from 10 m, under the
// camera.
inline void AddPersonUnderCamera(v1::AddMeasurementRequest& request) {
  v1::PixelBox* box = request.mutable_detections()->add_boxes();
  box->set_x_min_px(180);
  box->set_y_min_px(260);
  box->set_x_max_px(300);
  box->set_y_max_px(380);
  box->set_confidence(0.9);
}

// Labels for the cells under a camera at (x, y): a 3 x 3 block of cells
// around the cell holding (x, y) on the 20 x 20 small field.
inline v1::AddMeasurementRequest LabelMeasurement(const std::string& name, double x, double y,
                                                  double z, double time_s, double label) {
  v1::AddMeasurementRequest request;
  request.set_name(name);
  request.set_mission_time_s(time_s);
  request.mutable_camera_position_m()->set_x(x);
  request.mutable_camera_position_m()->set_y(y);
  request.mutable_camera_position_m()->set_z(z);
  const int col = std::clamp(static_cast<int>((x + 7.5) / 0.75), 1, 18);
  const int row = std::clamp(static_cast<int>((y + 7.5) / 0.75), 1, 18);
  for (int dr = -1; dr <= 1; ++dr) {
    for (int dc = -1; dc <= 1; ++dc) {
      request.mutable_labels()->add_cells((row + dr) * 20 + col + dc);
      request.mutable_labels()->add_labels(label);
    }
  }
  return request;
}

}  // namespace oaipp::server::testing
