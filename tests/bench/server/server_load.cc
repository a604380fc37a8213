// Many missions at once on one server: each flies the E1 mission for its
// budget (plan, fly the path in simulated time, measure at the sensor's
// shots, replan), all concurrently over loopback TCP. Prints throughput,
// per-method latency percentiles and memory per mission. With several
// --stores the same load runs once on each, one after the other, and the
// wall times are compared with the first.
//
//   build/tests/bench/server/server_load --missions=50 --budget_s=150
//   build/tests/bench/server/server_load --missions=50 --stores=memory,sqlite
#include <unistd.h>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <mutex>
#include <thread>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/str_cat.h"
#include "grpcpp/grpcpp.h"
#include "server/service.h"
#include "server/store/open_store.h"
#include "spdlog/spdlog.h"
#include "tests/bench/server/e1_mission.h"
#include "tests/bench/server/latencies.h"
#include "tests/server/postgres_instance.h"

ABSL_FLAG(int, missions, 50, "missions flown at once");
ABSL_FLAG(double, budget_s, 150.0, "flight budget per mission, seconds");
ABSL_FLAG(int, generations, 45, "CMA-ES generations per plan");
ABSL_FLAG(int, planning_threads, 2, "server planning pool size");
ABSL_FLAG(int, prior_cache, 4, "server prior cache size (0: every mission computes its prior)");
ABSL_FLAG(std::vector<std::string>, stores, {"memory"},
          "stores to run the load on, in turn: memory, sqlite (in a fresh folder under "
          "--data_dir), postgresql (a PostgreSQL server started for the run, as the tests "
          "start one) or a postgresql:// URI");
ABSL_FLAG(std::string, data_dir, "/tmp/oaipp-server-load", "where sqlite runs keep their file");
ABSL_FLAG(int, snapshot_every, 16, "server snapshot interval (measurements)");

namespace {

using Clock = std::chrono::steady_clock;

using oaipp::bench::Latencies;

}  // namespace

// Flies the load against a fresh server on `store` (nullptr: memory);
// returns the wall time in seconds.
double RunLoad(oaipp::server::MissionStore* store) {
  const int missions = absl::GetFlag(FLAGS_missions);
  const double budget = absl::GetFlag(FLAGS_budget_s);
  using namespace oaipp;
  server::MissionRegistry registry({.max_missions = missions + 1,
                                    .prior_cache = absl::GetFlag(FLAGS_prior_cache),
                                    .snapshot_every = absl::GetFlag(FLAGS_snapshot_every)},
                                   store);
  server::PlanningPool planners(absl::GetFlag(FLAGS_planning_threads), 4 * missions);
  server::MissionServiceImpl service(&registry, &planners, nullptr);
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  auto channel =
      grpc::CreateChannel(absl::StrCat("127.0.0.1:", port), grpc::InsecureChannelCredentials());
  auto stub = v1::MissionService::NewStub(channel);

  Latencies latencies;
  std::atomic<int> done{0};
  std::atomic<std::int64_t> map_bytes{0};
  auto timed = [&](const char* method, auto call) {
    const auto t0 = Clock::now();
    const grpc::Status status = call();
    latencies.Add(method, std::chrono::duration<double, std::milli>(Clock::now() - t0).count(),
                  status.ok());
    return status;
  };
  const auto start = Clock::now();
  std::vector<std::thread> threads;
  for (int m = 0; m < missions; ++m) {
    threads.emplace_back([&, m] {
      const std::string id = absl::StrCat("load-", m);
      const std::string name = "missions/" + id;
      v1::Mission created;
      timed("CreateMission", [&] {
        grpc::ClientContext c;
        v1::CreateMissionRequest r;
        r.set_mission_id(id);
        *r.mutable_spec() = bench::E1Spec(absl::GetFlag(FLAGS_generations));
        r.mutable_spec()->mutable_planner()->set_seed(static_cast<std::uint32_t>(m + 1));
        r.mutable_spec()->set_budget_s(budget);
        return stub->CreateMission(&c, r, &created);
      });
      map_bytes += created.map_bytes();
      v1::UavState state = created.spec().start();
      int shots = 0;
      while (state.mission_time_s() < budget) {
        v1::PlanPathResponse path;
        const grpc::Status planned = timed("PlanPath", [&] {
          grpc::ClientContext c;
          c.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
          v1::PlanPathRequest r;
          r.set_name(name);
          *r.mutable_state() = state;
          r.set_request_id(absl::StrCat("plan-", state.mission_time_s()));
          return stub->PlanPath(&c, r, &path);
        });
        if (!planned.ok()) break;
        const double fly =
            std::min(path.trajectory().duration_s(), budget - state.mission_time_s());
        for (const auto& pose : path.measurement_poses()) {
          if (pose.t_s() > fly) break;
          timed("AddMeasurement", [&] {
            grpc::ClientContext c;
            v1::AddMeasurementRequest r =
                bench::E1Measurement(name, pose.position_m(), pose.mission_time_s());
            r.set_request_id(absl::StrCat("shot-", shots++));
            v1::AddMeasurementResponse out;
            return stub->AddMeasurement(&c, r, &out);
          });
        }
        const auto& last = path.trajectory().samples(path.trajectory().samples_size() - 1);
        *state.mutable_position_m() = last.position_m();
        state.set_mission_time_s(state.mission_time_s() + path.trajectory().duration_s());
      }
      timed("GetMap", [&] {
        grpc::ClientContext c;
        v1::GetMapRequest r;
        r.set_name(name);
        v1::GetMapResponse out;
        return stub->GetMap(&c, r, &out);
      });
      ++done;
    });
  }
  for (auto& t : threads) t.join();
  const double wall = std::chrono::duration<double>(Clock::now() - start).count();
  std::printf("%d missions of %.0f s flight each, %d finished, wall %.1f s, %d planning threads\n",
              missions, budget, done.load(), wall, absl::GetFlag(FLAGS_planning_threads));
  std::printf("memory per mission (map + ESDF): %.1f MB\n",
              static_cast<double>(map_bytes.load()) / missions / 1e6);
  latencies.Print(wall);
  server->Shutdown();
  registry.FlushSnapshots();
  std::printf("snapshots written: %lld\n", static_cast<long long>(registry.snapshots_written()));
  return wall;
}

int main(int argc, char** argv) {
  absl::ParseCommandLine(argc, argv);
  spdlog::set_level(spdlog::level::warn);
  std::vector<std::pair<std::string, double>> walls;
  std::unique_ptr<oaipp::server::testing::PostgresInstance> postgres;
  for (std::string kind : absl::GetFlag(FLAGS_stores)) {
    const std::string label = kind;
    if (kind == "postgresql") {
      if (postgres == nullptr) {
        postgres = std::make_unique<oaipp::server::testing::PostgresInstance>();
        if (!oaipp::server::testing::PostgresInstance::Available() || !postgres->Start()) {
          std::fprintf(stderr, "cannot start PostgreSQL 15 (deploy/install-deps.sh installs it)\n");
          return 1;
        }
      }
      const std::string database = absl::StrCat("load", walls.size());
      if (!postgres->CreateDatabase(database)) return 1;
      kind = postgres->uri(database);
    }
    const std::string dir =
        absl::StrCat(absl::GetFlag(FLAGS_data_dir), "/run-", walls.size(), "-", getpid());
    std::filesystem::remove_all(dir);
    absl::StatusOr<std::unique_ptr<oaipp::server::MissionStore>> store =
        oaipp::server::OpenStore(kind, dir);
    if (!store.ok()) {
      std::fprintf(stderr, "%s\n", store.status().ToString().c_str());
      return 1;
    }
    std::printf("== store: %s\n", oaipp::server::DescribeStore(kind, dir).c_str());
    std::fflush(stdout);
    walls.emplace_back(label, RunLoad(store->get()));
    store->reset();
    std::filesystem::remove_all(dir);
  }
  if (walls.size() > 1) {
    std::printf("\nwall time against %s:\n", walls.front().first.c_str());
    for (const auto& [kind, wall] : walls) {
      std::printf("  %-12.12s %8.1f s  %.3f\n", kind.c_str(), wall, wall / walls.front().second);
    }
  }
  return 0;
}
