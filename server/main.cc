// oaipp-server: the OA-IPP planning service.
//
//   oaipp-server --listen=127.0.0.1:50051 --metrics_listen=127.0.0.1:9464 --data_dir=./data
//
// Missions are kept in --data_dir/missions.db (SQLite), or in PostgreSQL
// with --store=postgresql://..., and come back after a restart or a crash;
// --store=memory keeps them in memory only.
//
// Health checking (grpc.health.v1) and server reflection are on. SIGTERM or
// SIGINT: stop accepting calls, let in-flight calls finish (up to
// --shutdown_grace_s), exit 0.
#include <csignal>
#include <memory>
#include <thread>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/synchronization/notification.h"
#include "grpcpp/ext/proto_server_reflection_plugin.h"
#include "grpcpp/grpcpp.h"
#include "grpcpp/health_check_service_interface.h"
#include "prometheus/exposer.h"
#include "server/service.h"
#include "server/store/open_store.h"
#include "spdlog/spdlog.h"

ABSL_FLAG(std::string, listen, "127.0.0.1:50051", "gRPC listen address (host:port)");
ABSL_FLAG(int, worker_threads, 16, "most threads serving RPCs at once");
ABSL_FLAG(int, planning_threads, 2, "plans that may run at once");
ABSL_FLAG(int, planning_queue, 16, "plans that may wait; more are refused (RESOURCE_EXHAUSTED)");
ABSL_FLAG(int, max_missions, 64, "missions held at once");
ABSL_FLAG(int64_t, max_cells, 4096,
          "cells per mission map (its covariance takes 8 n^2 bytes: 4096 cells = 134 MB)");
ABSL_FLAG(int, prior_cache, 4,
          "prior covariances kept for missions over the same kind of field (8 n^2 bytes each; "
          "0: every mission computes its own)");
ABSL_FLAG(std::string, log_level, "info", "trace, debug, info, warn, error or off");
ABSL_FLAG(std::string, metrics_listen, "127.0.0.1:9464",
          "Prometheus metrics address (host:port); empty disables");
ABSL_FLAG(std::string, store, "sqlite",
          "where missions are kept: sqlite (one file, missions.db, under --data_dir), a "
          "PostgreSQL URI (postgresql://user@host:port/db; for several servers), or memory "
          "(lost on restart); with a store every acknowledged change is durable first");
ABSL_FLAG(std::string, data_dir, "./data",
          "folder of the sqlite store (created at start); back it up with sqlite3's .backup");
ABSL_FLAG(double, shutdown_grace_s, 10.0, "time in-flight calls get to finish on SIGTERM");
ABSL_FLAG(int, snapshot_every, 16,
          "with a store: snapshot a mission's map and state after this many measurements (or 4x "
          "as many records) since its last one, so recovery replays at most that many; 0: never");
ABSL_FLAG(int, recovery_threads, 2, "threads that rebuild missions from the store at start");
ABSL_FLAG(absl::Duration, keep_finished, absl::Hours(7 * 24),
          "how long a mission whose flight budget is spent is kept after its last change, "
          "then deleted with its records ('inf': forever)");
ABSL_FLAG(absl::Duration, keep_idle, absl::Hours(30 * 24),
          "how long any mission is kept after its last change ('inf': forever)");

int main(int argc, char** argv) {
  absl::SetProgramUsageMessage("OA-IPP planning service (oaipp.v1.MissionService)");
  absl::ParseCommandLine(argc, argv);
  spdlog::set_level(spdlog::level::from_str(absl::GetFlag(FLAGS_log_level)));
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");

  const int threads = absl::GetFlag(FLAGS_worker_threads);
  const int planning_threads = absl::GetFlag(FLAGS_planning_threads);
  const int planning_queue = absl::GetFlag(FLAGS_planning_queue);
  if (threads < 2 || planning_threads < 1 || planning_queue < 0 ||
      absl::GetFlag(FLAGS_max_missions) < 1 || absl::GetFlag(FLAGS_max_cells) < 1 ||
      absl::GetFlag(FLAGS_snapshot_every) < 0 || absl::GetFlag(FLAGS_recovery_threads) < 1 ||
      absl::GetFlag(FLAGS_keep_finished) <= absl::ZeroDuration() ||
      absl::GetFlag(FLAGS_keep_idle) <= absl::ZeroDuration() ||
      absl::GetFlag(FLAGS_prior_cache) < 0) {
    spdlog::error(
        "bad flags: need worker_threads >= 2, planning_threads >= 1, "
        "planning_queue >= 0, max_missions >= 1, max_cells >= 1, prior_cache >= 0, "
        "snapshot_every >= 0, recovery_threads >= 1, keep_finished > 0, keep_idle > 0");
    return 2;
  }

  // Signals are taken by a thread of ours, not by whichever thread runs.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  std::unique_ptr<oaipp::server::MissionStore> store;
  {
    const std::string kind = absl::GetFlag(FLAGS_store);
    const std::string dir = absl::GetFlag(FLAGS_data_dir);
    absl::StatusOr<std::unique_ptr<oaipp::server::MissionStore>> opened =
        oaipp::server::OpenStore(kind, dir);
    if (!opened.ok()) {
      spdlog::error("{}", opened.status().ToString());
      return opened.status().code() == absl::StatusCode::kInvalidArgument ? 2 : 1;
    }
    store = *std::move(opened);
    spdlog::info("store: {}", oaipp::server::DescribeStore(kind, dir));
  }

  oaipp::server::MissionRegistry registry(
      {.max_missions = absl::GetFlag(FLAGS_max_missions),
       .max_cells_per_mission = absl::GetFlag(FLAGS_max_cells),
       .prior_cache = absl::GetFlag(FLAGS_prior_cache),
       .snapshot_every = absl::GetFlag(FLAGS_snapshot_every),
       .recovery_threads = absl::GetFlag(FLAGS_recovery_threads)},
      store.get());
  {
    const absl::Time started = absl::Now();
    absl::StatusOr<int> recovered = registry.Recover();
    if (!recovered.ok()) {
      spdlog::error("store: {}", recovered.status().ToString());
      return 1;
    }
    if (store != nullptr) {
      spdlog::info("store: recovered {} missions in {:.3f} s", *recovered,
                   absl::ToDoubleSeconds(absl::Now() - started));
    }
  }
  oaipp::server::PlanningGate gate(planning_threads, planning_queue);
  oaipp::server::Metrics metrics;
  std::unique_ptr<prometheus::Exposer> exposer;
  if (const std::string address = absl::GetFlag(FLAGS_metrics_listen); !address.empty()) {
    try {
      exposer = std::make_unique<prometheus::Exposer>(address);
      exposer->RegisterCollectable(metrics.registry());
    } catch (const std::exception& e) {
      spdlog::error("metrics: cannot listen on {}: {}", address, e.what());
      return 1;
    }
  }
  oaipp::server::MissionServiceImpl service(&registry, &gate, &metrics);

  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort(absl::GetFlag(FLAGS_listen), grpc::InsecureServerCredentials(), &port);
  grpc::ResourceQuota quota("oaipp-server");
  quota.SetMaxThreads(threads);
  builder.SetResourceQuota(quota);
  builder.SetMaxReceiveMessageSize(64 << 20);
  // Idle serving threads wake up this often; it bounds how long shutdown
  // waits for them once the last call has finished.
  builder.SetSyncServerOption(grpc::ServerBuilder::SyncServerOption::CQ_TIMEOUT_MSEC, 200);
  builder.RegisterService(&service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (server == nullptr || port == 0) {
    spdlog::error("cannot listen on {}", absl::GetFlag(FLAGS_listen));
    return 1;
  }
  server->GetHealthCheckService()->SetServingStatus("oaipp.v1.MissionService", true);
  server->GetHealthCheckService()->SetServingStatus(true);
  spdlog::info(
      "oaipp-server listening on {} (metrics on {})", absl::GetFlag(FLAGS_listen),
      absl::GetFlag(FLAGS_metrics_listen).empty() ? "-" : absl::GetFlag(FLAGS_metrics_listen));

  // Health follows the store: NOT_SERVING while it cannot be written (the
  // disk gone or full), so that a balancer sends calls elsewhere.
  absl::Notification stopping;
  std::thread store_watch([&] {
    if (store == nullptr) return;
    bool healthy = true;
    while (!stopping.WaitForNotificationWithTimeout(absl::Seconds(1))) {
      const absl::Status status = store->Health();
      if (status.ok() != healthy) {
        healthy = status.ok();
        if (healthy) {
          spdlog::info("store: writable again; SERVING");
        } else {
          spdlog::warn("store: {}; NOT_SERVING", status.ToString());
        }
        server->GetHealthCheckService()->SetServingStatus("oaipp.v1.MissionService", healthy);
      }
    }
  });

  // Retention: finished and idle missions leave memory and the store.
  std::thread sweeper([&] {
    const absl::Duration keep_finished = absl::GetFlag(FLAGS_keep_finished);
    const absl::Duration keep_idle = absl::GetFlag(FLAGS_keep_idle);
    const absl::Duration every =
        std::clamp(std::min(keep_finished, keep_idle) / 10, absl::Seconds(1), absl::Minutes(1));
    while (!stopping.WaitForNotificationWithTimeout(every)) {
      for (const std::string& id : registry.Sweep(absl::Now(), keep_finished, keep_idle)) {
        spdlog::info("mission event=expired name=missions/{}", id);
      }
    }
  });

  std::thread waiter([&] {
    int signal = 0;
    sigwait(&signals, &signal);
    spdlog::info("signal {}: no new calls; finishing the ones in flight", signal);
    stopping.Notify();
    server->GetHealthCheckService()->SetServingStatus(false);
    const auto grace = std::chrono::milliseconds(
        static_cast<int64_t>(absl::GetFlag(FLAGS_shutdown_grace_s) * 1000));
    server->Shutdown(std::chrono::system_clock::now() + grace);
  });
  server->Wait();
  // Snapshots already asked for are written, so that the next start replays
  // short tails.
  registry.FlushSnapshots();
  waiter.join();
  store_watch.join();
  sweeper.join();
  spdlog::info("oaipp-server stopped");
  return 0;
}
