// What durability costs: AddMeasurement on the E1 mission through the
// service in-process, with the SQLite store (every call on disk before it is
// answered) and with missions in memory, alternated in the same run; a bare
// store append (the fsync); and how long recovery takes.
//
//   build/tests/bench/server/store_bench --benchmark_repetitions=5
//     (add --benchmark_report_aggregates_only=true for medians only)
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <vector>

#include "absl/strings/str_cat.h"
#include "grpcpp/grpcpp.h"
#include "server/service.h"
#include "server/store/sqlite_store.h"
#include "tests/bench/server/e1_mission.h"

namespace oaipp {
namespace {

using Clock = std::chrono::steady_clock;

std::filesystem::path FreshDir(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / absl::StrCat("oaipp-bench-", getpid(), "-", name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// A service in-process over `store` (nullptr: memory) holding missions.
struct Service {
  explicit Service(server::MissionStore* store) : registry({.max_missions = 128}, store) {
    grpc::ServerBuilder builder;
    builder.RegisterService(&service);
    server = builder.BuildAndStart();
    stub = v1::MissionService::NewStub(server->InProcessChannel(grpc::ChannelArguments()));
  }
  ~Service() { server->Shutdown(); }
  void Create(const std::string& id) {
    grpc::ClientContext c;
    v1::CreateMissionRequest r;
    r.set_mission_id(id);
    *r.mutable_spec() = bench::E1Spec();
    v1::Mission m;
    (void)stub->CreateMission(&c, r, &m);
  }
  // One measurement from 10 m over a place that moves with `k`.
  double Measure(const std::string& id, int k) {
    v1::Vector3 p;
    p.set_x(-12 + (k * 7) % 24);
    p.set_y(-12 + (k * 5) % 24);
    p.set_z(10);
    v1::AddMeasurementRequest r = bench::E1Measurement("missions/" + id, p, 0.1 * k);
    r.set_request_id(absl::StrCat("m", k));
    grpc::ClientContext c;
    v1::AddMeasurementResponse out;
    const auto t0 = Clock::now();
    (void)stub->AddMeasurement(&c, r, &out);
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  }
  server::MissionRegistry registry;
  server::PlanningGate gate{2, 16};
  server::MissionServiceImpl service{&registry, &gate, nullptr};
  std::unique_ptr<grpc::Server> server;
  std::unique_ptr<v1::MissionService::Stub> stub;
};

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

// Both services measure in turn each iteration; counters: the median of
// each and their difference (what durability adds per call).
void BM_AddMeasurementSqliteVsMemory(benchmark::State& state) {
  const std::filesystem::path dir = FreshDir("measure");
  auto store = *server::OpenSqliteStore((dir / "missions.db").string());
  Service durable(store.get()), memory(nullptr);
  durable.Create("e1");
  memory.Create("e1");
  std::vector<double> durable_ms, memory_ms;
  int k = 0;
  for (auto _ : state) {
    durable_ms.push_back(durable.Measure("e1", k));
    memory_ms.push_back(memory.Measure("e1", k));
    ++k;
  }
  state.counters["sqlite_p50_ms"] = Median(durable_ms);
  state.counters["memory_p50_ms"] = Median(memory_ms);
  state.counters["added_p50_ms"] = Median(durable_ms) - Median(memory_ms);
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_AddMeasurementSqliteVsMemory)->Iterations(200)->Unit(benchmark::kMillisecond);

// A bare append of a measurement-sized record: the cost of one durable
// SQLite transaction (WAL, synchronous=FULL: one fsync) on this disk.
void BM_SqliteAppend(benchmark::State& state) {
  const std::filesystem::path dir = FreshDir("append");
  auto store = *server::OpenSqliteStore((dir / "missions.db").string());
  (void)store->CreateMission({.id = "m", .spec = "spec"});
  const std::string payload(4000, 'x');
  std::int64_t sequence = 1;
  for (auto _ : state) {
    benchmark::DoNotOptimize(store->Append(
        "m",
        {.sequence = sequence++, .kind = server::RecordKind::kMeasurement, .payload = payload}));
  }
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_SqliteAppend)->Iterations(500)->Unit(benchmark::kMillisecond);

// Recovery of `missions` E1 missions with `measurements` each: the time
// Recover takes on a fresh registry over the written store.
void BM_Recover(benchmark::State& state) {
  const int missions = static_cast<int>(state.range(0));
  const int measurements = static_cast<int>(state.range(1));
  const std::filesystem::path dir = FreshDir("recover");
  {
    auto store = *server::OpenSqliteStore((dir / "missions.db").string());
    Service writer(store.get());
    for (int m = 0; m < missions; ++m) {
      const std::string id = absl::StrCat("e1-", m);
      writer.Create(id);
      for (int k = 0; k < measurements; ++k) writer.Measure(id, k);
    }
  }
  for (auto _ : state) {
    auto store = *server::OpenSqliteStore((dir / "missions.db").string());
    server::MissionRegistry registry({.max_missions = missions}, store.get());
    const absl::StatusOr<int> recovered = registry.Recover();
    if (!recovered.ok() || *recovered != missions) state.SkipWithError("recovery failed");
  }
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_Recover)->Args({1, 2000})->Args({100, 22})->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace
}  // namespace oaipp
