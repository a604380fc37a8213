// What durability costs: AddMeasurement on the E1 mission through the
// service in-process, with the SQLite store, with PostgreSQL (a real server
// the benchmark starts on loopback, as the tests do) and with missions in
// memory, in turn in the same run; a bare store append (the fsync, or the
// round trip and commit); appends of many missions at once (group commit);
// how long recovery takes with snapshots; and what restoring one mission
// from its snapshot costs (a takeover's share of CPU once the bytes are read).
//
//   build/tests/bench/server/store_bench --benchmark_repetitions=5
//     (add --benchmark_report_aggregates_only=true for medians only)
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "api/spec.h"
#include "grpcpp/grpcpp.h"
#include "server/server.h"
#include "server/service.h"
#include "server/store/postgres_store.h"
#include "server/store/sqlite_store.h"
#include "server/store/state_codec.h"
#include "tests/bench/server/e1_mission.h"
#include "tests/server/postgres_instance.h"

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

// One PostgreSQL server for the whole run, started on first use; each
// benchmark takes its own database.
std::string PostgresUri() {
  static std::unique_ptr<server::testing::PostgresInstance> postgres;
  static int databases = 0;
  if (postgres == nullptr) {
    if (!server::testing::PostgresInstance::Available()) return "";
    postgres = std::make_unique<server::testing::PostgresInstance>();
    if (!postgres->Start()) return "";
  }
  const std::string database = absl::StrCat("bench", ++databases);
  return postgres->CreateDatabase(database) ? postgres->uri(database) : "";
}

// The store of kind 0 (SQLite, in a fresh folder) or 1 (PostgreSQL, a fresh
// database); nullptr when it cannot be had.
std::unique_ptr<server::MissionStore> OpenKind(int kind, const std::string& name) {
  absl::StatusOr<std::unique_ptr<server::MissionStore>> store =
      kind == 0 ? server::OpenSqliteStore((FreshDir(name) / "missions.db").string())
                : server::OpenPostgresStore(PostgresUri());
  return store.ok() ? *std::move(store) : nullptr;
}

// A service in-process over `store` (nullptr: memory) holding missions.
// The real server (Server::Start) on `store`, in process only.
struct Service {
  explicit Service(server::MissionStore* store)
      : server(Start(store)),
        registry(server->registry()),
        stub(v1::MissionService::NewStub(server->InProcessChannel())) {}
  static std::unique_ptr<server::Server> Start(server::MissionStore* store) {
    server::ServerOptions options;
    options.listen = "";
    options.metrics_listen = "";
    return *server::Server::Start(options, {.registry = {.max_missions = 128},
                                            .planning_threads = 2,
                                            .planning_queue = 16,
                                            .store = store});
  }
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
  std::unique_ptr<server::Server> server;
  server::MissionRegistry& registry;
  std::unique_ptr<v1::MissionService::Stub> stub;
};

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

// The three services measure in turn each iteration; counters: the median
// of each and what each store adds to it.
void BM_AddMeasurementStoresVsMemory(benchmark::State& state) {
  std::unique_ptr<server::MissionStore> sqlite = OpenKind(0, "measure");
  std::unique_ptr<server::MissionStore> postgres = OpenKind(1, "measure");
  if (sqlite == nullptr || postgres == nullptr) {
    state.SkipWithError("a store could not be opened");
    return;
  }
  Service on_sqlite(sqlite.get()), on_postgres(postgres.get()), memory(nullptr);
  for (Service* s : {&on_sqlite, &on_postgres, &memory}) s->Create("e1");
  std::vector<double> sqlite_ms, postgres_ms, memory_ms;
  int k = 0;
  for (auto _ : state) {
    sqlite_ms.push_back(on_sqlite.Measure("e1", k));
    postgres_ms.push_back(on_postgres.Measure("e1", k));
    memory_ms.push_back(memory.Measure("e1", k));
    ++k;
  }
  state.counters["memory_p50_ms"] = Median(memory_ms);
  state.counters["sqlite_p50_ms"] = Median(sqlite_ms);
  state.counters["postgres_p50_ms"] = Median(postgres_ms);
  state.counters["sqlite_added_ms"] = Median(sqlite_ms) - Median(memory_ms);
  state.counters["postgres_added_ms"] = Median(postgres_ms) - Median(memory_ms);
}
BENCHMARK(BM_AddMeasurementStoresVsMemory)->Iterations(200)->Unit(benchmark::kMillisecond);

// A bare append of a measurement-sized record: one durable transaction
// (SQLite: WAL, synchronous=FULL, one fsync; PostgreSQL: a loopback round
// trip and a commit that waits for its WAL flush). Arg: 0 SQLite, 1 PostgreSQL.
void BM_Append(benchmark::State& state) {
  std::unique_ptr<server::MissionStore> store =
      OpenKind(static_cast<int>(state.range(0)), "append");
  if (store == nullptr) {
    state.SkipWithError("the store could not be opened");
    return;
  }
  (void)store->CreateMission({.id = "m", .spec = "spec"});
  const std::string payload(4000, 'x');
  std::int64_t sequence = 1;
  for (auto _ : state) {
    benchmark::DoNotOptimize(store->Append(
        "m",
        {.sequence = sequence++, .kind = server::RecordKind::kMeasurement, .payload = payload}));
  }
}
BENCHMARK(BM_Append)->Arg(0)->Arg(1)->Iterations(500)->Unit(benchmark::kMillisecond);

// 16 missions appending at once, 50 records each: appends per second.
// SQLite commits whatever is queued in one transaction (one fsync for the
// group); PostgreSQL spreads missions over its connections.
void BM_ConcurrentAppends(benchmark::State& state) {
  std::unique_ptr<server::MissionStore> store =
      OpenKind(static_cast<int>(state.range(0)), "concurrent");
  if (store == nullptr) {
    state.SkipWithError("the store could not be opened");
    return;
  }
  constexpr int kMissions = 16, kRecords = 50;
  const std::string payload(4000, 'x');
  int round = 0;
  double appends = 0, seconds = 0;
  for (auto _ : state) {
    for (int m = 0; m < kMissions; ++m) {
      (void)store->CreateMission({.id = absl::StrCat("r", round, "m", m), .spec = "spec"});
    }
    const auto t0 = Clock::now();
    std::vector<std::thread> writers;
    for (int m = 0; m < kMissions; ++m) {
      writers.emplace_back([&, m] {
        const std::string id = absl::StrCat("r", round, "m", m);
        for (int i = 1; i <= kRecords; ++i) {
          (void)store->Append(
              id, {.sequence = i, .kind = server::RecordKind::kMeasurement, .payload = payload});
        }
      });
    }
    for (std::thread& t : writers) t.join();
    seconds += std::chrono::duration<double>(Clock::now() - t0).count();
    appends += kMissions * kRecords;
    ++round;
  }
  state.counters["appends_per_s"] = appends / seconds;
}
BENCHMARK(BM_ConcurrentAppends)->Arg(0)->Arg(1)->Iterations(3)->Unit(benchmark::kMillisecond);

// Recovery of `missions` E1 missions with `measurements` each, written with
// a snapshot every 16 measurements (the server's default): the time Recover
// takes on a fresh registry over the SQLite file.
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
    writer.registry.FlushSnapshots();
    state.counters["snapshots"] = static_cast<double>(writer.registry.snapshots_written());
  }
  for (auto _ : state) {
    auto store = *server::OpenSqliteStore((dir / "missions.db").string());
    server::MissionRegistry registry({.max_missions = missions}, store.get());
    // The registry's own recovery: what a server's start spends on it.
    const absl::StatusOr<int> recovered = registry.Recover();
    if (!recovered.ok() || *recovered != missions) state.SkipWithError("recovery failed");
  }
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_Recover)->Args({1, 2000})->Args({100, 22})->Iterations(1)->Unit(benchmark::kSecond);

// What a takeover spends on one mission once its snapshot's bytes are in
// hand: decoding the snapshot, and restoring the mission from it (the world
// and a sparse map's prior from the site's caches, as on a replica holding
// missions over the same site). Arg 0: an E1 mission; arg 1: E1's spec on a 300 x 300 m field at
// 1 m (90,000 cells, the sparse map; the ground under its buildings fused
// as on creation); arg 2: the same from a snapshot without the trace, as
// written before snapshots kept it (the restore computes the variance map
// first). Counters:
// milliseconds of each, medians over the iterations.
void BM_RestoreFromSnapshot(benchmark::State& state) {
  EsdfPool esdfs;
  WorldCache worlds;
  GmrfPriorCache gmrf_priors;
  const server::SiteCaches caches{.esdfs = &esdfs, .worlds = &worlds, .gmrf_priors = &gmrf_priors};
  v1::MissionSpec spec = bench::E1Spec();
  const bool large = state.range(0) >= 1;
  if (large) {
    v1::FieldSpec* field = spec.mutable_field();
    field->set_x_min_m(-150);
    field->set_y_min_m(-150);
    field->set_x_max_m(150);
    field->set_y_max_m(150);
    field->set_resolution_m(1.0);
    field->set_map_backend(v1::MAP_BACKEND_SPARSE);
    spec.mutable_flight()->set_esdf_voxel_m(1.0);
  }
  absl::StatusOr<api::MissionConfig> config = api::MissionSpecToConfig(spec);
  if (!config.ok()) {
    state.SkipWithError("spec");
    return;
  }
  absl::StatusOr<std::shared_ptr<server::Mission>> mission =
      server::Mission::Create("m", *config, caches);
  if (!mission.ok()) {
    state.SkipWithError("create");
    return;
  }
  server::MissionState captured = (*mission)->CaptureState();
  if (state.range(0) == 2) captured.trace.reset();
  const std::string bytes = server::EncodeMissionState(captured);
  std::vector<double> decode_ms, restore_ms;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    absl::StatusOr<server::MissionState> decoded = server::DecodeMissionState(bytes);
    const auto t1 = Clock::now();
    absl::StatusOr<std::shared_ptr<server::Mission>> restored =
        server::Mission::Restore("m", *config, *std::move(decoded), caches);
    const auto t2 = Clock::now();
    if (!restored.ok()) state.SkipWithError("restore");
    decode_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    restore_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
  }
  state.counters["snapshot_mb"] = static_cast<double>(bytes.size()) / 1e6;
  state.counters["decode_ms"] = Median(decode_ms);
  state.counters["restore_ms"] = Median(restore_ms);
}
BENCHMARK(BM_RestoreFromSnapshot)->Arg(0)->Iterations(20)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RestoreFromSnapshot)->Arg(1)->Arg(2)->Iterations(3)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace oaipp
