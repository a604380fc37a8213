// A large-field mission through the whole service, in process: E6's world
// (client/scenarios/e6.json: 300 x 300 m at 1 m, 90,000 cells on the
// sparse map, 50 buildings) flown plan by plan with the simulated
// detector's boxes of a 480 x 640 image at every planned shot.
//
// Per call it times CreateMission, PlanPath (the map brought up to date,
// the planner's window and the plan), AddMeasurement (the image's boxes
// projected and fused) and the variance map after it (GetMap right after
// the measurement: it waits for the mean and every variance of the map as
// it now is). It prints medians, 95th percentiles and the process's peak
// memory, for docs/benchmarks.md.
//
// With --server it flies against a running oaipp-server instead, and with
// --server_pid it reports that process's peak memory (VmHWM).
//
//   build/tests/bench/server/large_field_mission --shots=40
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/str_cat.h"
#include "api/geometry.h"
#include "api/measurement.h"
#include "api/plan.h"
#include "grpcpp/grpcpp.h"
#include "oaipp/v1/mission_service.grpc.pb.h"
#include "server/library_settings.h"
#include "server/server.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "tests/bench/server/latencies.h"

ABSL_FLAG(int, shots, 40, "measurements to fuse (the plans needed for them are flown)");
ABSL_FLAG(std::string, scenario, OAIPP_SCENARIO_DIR "/e6.json", "the scenario to fly");
ABSL_FLAG(std::string, server, "", "a running server's address (empty: one in process)");
ABSL_FLAG(int, server_pid, 0, "that server's process id, for its peak memory (0: not reported)");

namespace oaipp {
namespace {

using Clock = std::chrono::steady_clock;
using bench::MsSince;

int Run() {
  absl::StatusOr<v1::Scenario> scenario = sim::LoadScenarioFile(absl::GetFlag(FLAGS_scenario));
  absl::StatusOr<sim::Simulation> simulation =
      scenario.ok() ? sim::Simulation::Create(*scenario)
                    : absl::StatusOr<sim::Simulation>(scenario.status());
  if (!simulation.ok()) {
    std::cerr << "scenario: " << simulation.status() << "\n";
    return 2;
  }
  std::unique_ptr<server::Server> in_process;
  std::shared_ptr<grpc::Channel> channel;
  if (absl::GetFlag(FLAGS_server).empty()) {
    server::ServerOptions options;
    options.listen = "";
    options.metrics_listen = "";
    absl::StatusOr<std::unique_ptr<server::Server>> server =
        server::Server::Start(options, {.planning_threads = 1, .planning_queue = 4});
    if (!server.ok()) {
      std::cerr << "server: " << server.status() << "\n";
      return 2;
    }
    in_process = *std::move(server);
    channel = in_process->InProcessChannel();
  } else {
    channel = grpc::CreateChannel(absl::GetFlag(FLAGS_server), grpc::InsecureChannelCredentials());
  }
  auto stub = v1::MissionService::NewStub(channel);
  std::vector<double> create_ms, plan_ms, add_ms, variances_ms;

  Clock::time_point start = Clock::now();
  v1::Mission mission;
  {
    grpc::ClientContext context;
    v1::CreateMissionRequest request;
    *request.mutable_spec() = scenario->mission();
    if (const grpc::Status s = stub->CreateMission(&context, request, &mission); !s.ok()) {
      std::cerr << "CreateMission: " << s.error_message() << "\n";
      return 1;
    }
  }
  create_ms.push_back(MsSince(start));
  std::printf(
      "%s: %d x %d cells, map %s; created in %.2f s\n", mission.name().c_str(),
      static_cast<int>((mission.spec().field().x_max_m() - mission.spec().field().x_min_m()) /
                       mission.spec().field().resolution_m()),
      static_cast<int>((mission.spec().field().y_max_m() - mission.spec().field().y_min_m()) /
                       mission.spec().field().resolution_m()),
      v1::MapBackend_Name(mission.spec().field().map_backend()).c_str(), create_ms.back() / 1e3);

  std::mt19937_64 rng(scenario->seed());
  v1::UavState state = mission.spec().start();
  const int shots = absl::GetFlag(FLAGS_shots);
  int fused = 0;
  while (fused < shots) {
    v1::PlanPathRequest plan;
    plan.set_name(mission.name());
    *plan.mutable_state() = state;
    v1::PlanPathResponse path;
    start = Clock::now();
    {
      grpc::ClientContext context;
      if (const grpc::Status s = stub->PlanPath(&context, plan, &path); !s.ok()) {
        std::cerr << "PlanPath: " << s.error_message() << "\n";
        return 1;
      }
    }
    plan_ms.push_back(MsSince(start));
    for (const v1::MeasurementPose& shot : path.measurement_poses()) {
      if (fused == shots) break;
      const Vec3 camera = api::FromProto(shot.position_m());
      api::MeasurementInput input{.mission_time_s = shot.mission_time_s(),
                                  .pose = CameraPose{camera, 0.0}};
      input.detections = api::MeasurementInput::Detections{
          .intrinsics = simulation->intrinsics(),
          .boxes = simulation->Detect(camera, rng),
          .min_confidence = simulation->detector().min_confidence};
      v1::AddMeasurementRequest add;
      add.set_name(mission.name());
      api::MeasurementToProto(input, &add);
      v1::AddMeasurementResponse added;
      start = Clock::now();
      {
        grpc::ClientContext context;
        if (const grpc::Status s = stub->AddMeasurement(&context, add, &added); !s.ok()) {
          std::cerr << "AddMeasurement: " << s.error_message() << "\n";
          return 1;
        }
      }
      add_ms.push_back(MsSince(start));
      v1::GetMapRequest get;
      get.set_name(mission.name());
      v1::GetMapResponse map;
      {
        grpc::ClientContext context;
        if (const grpc::Status s = stub->GetMap(&context, get, &map); !s.ok()) {
          std::cerr << "GetMap: " << s.error_message() << "\n";
          return 1;
        }
      }
      variances_ms.push_back(MsSince(start));
      ++fused;
      std::printf("  shot %3d at t = %6.1f s: %d cells fused, Tr(P) %.1f\n", fused,
                  shot.mission_time_s(), added.cells_fused(), map.trace());
    }
    absl::StatusOr<PolynomialTrajectory> trajectory = api::TrajectoryFromProto(path.trajectory());
    if (!trajectory.ok()) {
      std::cerr << "trajectory: " << trajectory.status() << "\n";
      return 1;
    }
    const double end = trajectory->Duration();
    *state.mutable_position_m() = api::ToProto(trajectory->Position(end));
    *state.mutable_velocity_m_s() = api::ToProto(trajectory->Velocity(end));
    state.set_mission_time_s(state.mission_time_s() + end);
  }
  v1::Mission after;
  {
    grpc::ClientContext context;
    v1::GetMissionRequest get;
    get.set_name(mission.name());
    (void)stub->GetMission(&context, get, &after);
  }
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  std::printf("\n%-36s %10s %10s %6s\n", "call", "median", "p95", "n");
  const auto row = [](const char* what, std::vector<double>& ms) {
    const std::size_t n = ms.size();
    std::printf("%-36s %8.0f ms %8.0f ms %6zu\n", what, bench::Quantile(ms, 0.5),
                bench::Quantile(ms, 0.95), n);
  };
  row("PlanPath", plan_ms);
  row("AddMeasurement (480 x 640 image)", add_ms);
  row("the variance map after it", variances_ms);
  std::printf("mission memory (GetMission map_bytes): %.0f MB; process peak RSS: %.0f MB\n",
              static_cast<double>(after.map_bytes()) / 1e6,
              static_cast<double>(usage.ru_maxrss) / 1024.0);
  if (const int pid = absl::GetFlag(FLAGS_server_pid); pid > 0) {
    std::ifstream status(absl::StrCat("/proc/", pid, "/status"));
    for (std::string line; std::getline(status, line);) {
      if (line.rfind("VmHWM:", 0) == 0) std::printf("server process peak: %s\n", line.c_str() + 6);
    }
  }
  if (in_process != nullptr) in_process->Shutdown(absl::Seconds(5));
  return 0;
}

}  // namespace
}  // namespace oaipp

int main(int argc, char** argv) {
  // As the server does: the numeric libraries' threads (server/library_settings.h).
  if (!oaipp::server::SetUpNumericLibrariesOrSay()) return 1;
  absl::ParseCommandLine(argc, argv);
  return oaipp::Run();
}
