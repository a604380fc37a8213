// What the RPC layer costs: AddMeasurement and PlanPath on the E1 mission,
// called in-process on the mission object and over a loopback TCP channel,
// interleaved in the same run.
//
//   build/tests/bench/server/rpc_overhead_bench --benchmark_repetitions=5
//     (add --benchmark_report_aggregates_only=true for medians only)
#include <benchmark/benchmark.h>

#include <chrono>

#include "api/geometry.h"
#include "api/measurement.h"
#include "api/spec.h"
#include "grpcpp/grpcpp.h"
#include "server/server.h"
#include "server/service.h"
#include "tests/bench/server/e1_mission.h"

namespace oaipp {
namespace {

using Clock = std::chrono::steady_clock;

// The real server (Server::Start) on a loopback port, no store.
struct Loopback {
  std::unique_ptr<server::Server> server;
  std::unique_ptr<v1::MissionService::Stub> stub;
  std::shared_ptr<server::Mission> direct;  // a twin mission called in-process

  Loopback() {
    server::ServerOptions options;
    options.listen = "127.0.0.1:0";
    options.metrics_listen = "";
    server = *server::Server::Start(options, {.planning_threads = 2, .planning_queue = 16});
    stub = v1::MissionService::NewStub(grpc::CreateChannel(
        "127.0.0.1:" + std::to_string(server->port()), grpc::InsecureChannelCredentials()));
    grpc::ClientContext context;
    v1::CreateMissionRequest request;
    request.set_mission_id("rpc");
    *request.mutable_spec() = bench::E1Spec();
    v1::Mission mission;
    (void)stub->CreateMission(&context, request, &mission);
    direct = *server::Mission::Create("direct", *api::MissionSpecToConfig(bench::E1Spec()));
  }
};

Loopback& World() {
  static Loopback* world = new Loopback();
  return *world;
}

// Times `in_process` and `rpc` alternately each iteration (the RPC time is
// the benchmark's); counters give both means and their difference.
template <typename InProcess, typename Rpc>
void CompareInProcessAndRpc(benchmark::State& state, InProcess in_process, Rpc rpc) {
  double direct_s = 0, rpc_s = 0;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    in_process();
    const auto t1 = Clock::now();
    rpc();
    const auto t2 = Clock::now();
    direct_s += std::chrono::duration<double>(t1 - t0).count();
    rpc_s += std::chrono::duration<double>(t2 - t1).count();
    state.SetIterationTime(std::chrono::duration<double>(t2 - t1).count());
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["in_process_ms"] = 1e3 * direct_s / n;
  state.counters["rpc_ms"] = 1e3 * rpc_s / n;
  state.counters["overhead_ms"] = 1e3 * (rpc_s - direct_s) / n;
}

void BM_AddMeasurement(benchmark::State& state) {
  Loopback& w = World();
  v1::Vector3 p;
  p.set_x(2);
  p.set_y(-5);
  p.set_z(10);
  const v1::AddMeasurementRequest request = bench::E1Measurement("missions/rpc", p, 1.0);
  const api::MeasurementInput input = *api::MeasurementFromProto(request);
  // Both sides settle the covariance downdate the call leaves pending (the
  // server's background thread may get there first), so each times the
  // whole update, not how much of it overlaps the other side.
  const std::shared_ptr<server::Mission> served = *w.server->registry().Get("missions/rpc", "");
  CompareInProcessAndRpc(
      state,
      [&] {
        (void)w.direct->AddMeasurement(input, "");
        w.direct->SettleMap();
      },
      [&] {
        grpc::ClientContext context;
        v1::AddMeasurementResponse response;
        (void)w.stub->AddMeasurement(&context, request, &response);
        served->SettleMap();
      });
  state.counters["cells"] = request.labels().cells_size();
}
BENCHMARK(BM_AddMeasurement)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(20);

void BM_PlanPath(benchmark::State& state) {
  Loopback& w = World();
  v1::PlanPathRequest request;
  request.set_name("missions/rpc");
  request.mutable_state()->mutable_position_m()->set_x(10);
  request.mutable_state()->mutable_position_m()->set_z(7);
  const UavState uav = *api::UavStateFromProto(request.state(), "state");
  CompareInProcessAndRpc(
      state, [&] { (void)w.direct->Plan(uav, std::nullopt, "", {}); },
      [&] {
        grpc::ClientContext context;
        v1::PlanPathResponse response;
        (void)w.stub->PlanPath(&context, request, &response);
      });
}
BENCHMARK(BM_PlanPath)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(5);

}  // namespace
}  // namespace oaipp
