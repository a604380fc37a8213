// oaipp-server: the OA-IPP planning service.
//
//   oaipp-server --listen=127.0.0.1:50051 --metrics_listen=127.0.0.1:9464 --data_dir=./data
//
// Missions are kept in --data_dir/missions.db (SQLite), or in PostgreSQL
// with --store=postgresql://..., and come back after a restart or a crash;
// --store=memory keeps them in memory only.
//
// Health checking (grpc.health.v1) is on, and server reflection unless
// --reflection=false. TLS (--tls_cert, --tls_key; mutual with
// --tls_client_ca) and bearer tokens (--token_file) say who gets in; without
// TLS the server listens only on loopback unless --allow_insecure_remote.
// SIGTERM or SIGINT: stop accepting calls, let in-flight calls finish (up to
// --shutdown_grace_s), exit 0.
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <fstream>
#include <memory>
#include <sstream>
#include <thread>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/synchronization/notification.h"
#include "api/limits.h"
#include "core/mapping/dense_backend.h"
#include "core/planning/information.h"
#include "google/protobuf/stubs/logging.h"
#include "grpcpp/ext/proto_server_reflection_plugin.h"
#include "grpcpp/grpcpp.h"
#include "grpcpp/health_check_service_interface.h"
#include "grpcpp/impl/server_builder_option.h"
#include "grpcpp/impl/server_builder_plugin.h"
#include "server/auth.h"
#include "server/metrics_http.h"
#include "server/openblas_kernels.h"
#include "server/service.h"
#include "server/stop_signals.h"
#include "server/store/open_store.h"
#include "server/web_view.h"
#include "spdlog/spdlog.h"

ABSL_FLAG(std::string, listen, "127.0.0.1:50051", "gRPC listen address (host:port)");
ABSL_FLAG(int, worker_threads, 16, "most threads serving RPCs at once");
ABSL_FLAG(int, planning_threads, 2, "plans that may run at once");
ABSL_FLAG(int, planning_queue, 16, "plans that may wait; more are refused (RESOURCE_EXHAUSTED)");
ABSL_FLAG(int, planning_nice, 10,
          "scheduling priority of the planning threads below the rest of the server (as nice(1), "
          "0..19): when the cores are full, measurements and new missions are answered before "
          "plans; 0 gives plans the same priority");
ABSL_FLAG(int, max_missions, 64, "missions held at once");
ABSL_FLAG(int64_t, max_cells, 4096,
          "cells per mission map (its covariance takes 8 n^2 bytes: 4096 cells = 134 MB)");
ABSL_FLAG(int, prior_cache, 4,
          "prior covariances kept for missions over the same kind of field, and as many starting "
          "maps (ground under buildings fused) for missions over the same site (8 n^2 bytes "
          "each; 0: every mission computes its own)");
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
ABSL_FLAG(int, max_streams, 256, "open WatchMission streams in all");
ABSL_FLAG(int, max_streams_per_client, 16,
          "open WatchMission streams per client (per tenant with --token_file, per connection "
          "without)");
ABSL_FLAG(int, max_plans_per_tenant, 0, "plans one tenant may have queued or running; 0: no quota");
ABSL_FLAG(double, max_planning_s, 60.0,
          "longest one plan may run; a plan asking for more (or no planning_budget_s) returns "
          "the best path found by then");
ABSL_FLAG(double, shed_above, 2.0,
          "overload: when more than this many plans per planning thread wait, a starting plan "
          "runs only (shed_above x planning_threads / waiting) of its search, at least "
          "--min_search_fraction (stats.search_fraction says so); 0: never shed");
ABSL_FLAG(std::string, dense_backend, "openblas",
          "where the Kalman update's rank-m product runs: openblas (Debian's libopenblas0-pthread, "
          "loaded at start; Eigen when it is missing or another build) or eigen");
ABSL_FLAG(
    std::string, objective_precision, "double",
    "the adaptive objective's solves: double, or single (OpenBLAS's kernels about twice as "
    "fast; 0.76-0.88 of double's CPU for 100 missions; a plan may differ from double's where two "
    "candidates tie, docs/capacity.md)");
ABSL_FLAG(double, min_search_fraction, 0.1, "the least share of its search a shed plan runs");
ABSL_FLAG(double, plan_latency_s, 0.0,
          "overload: a plan's search ends this many seconds after its call arrived, the wait "
          "for a planner included; plans queued together share the time until the newest "
          "one's bound; none searches less than a hundredth of it (it then returns its best "
          "path so far; stats.queued_s says how long it waited); 0: no bound. With a bound, "
          "--shed_above=0 is the better setting");
ABSL_FLAG(int, max_take_off_plans, 0,
          "take-off pacing: take-off plans (mission time 0, at rest) queued or running at once, "
          "none admitted while as many plans wait as there are planning threads; another is "
          "refused with RESOURCE_EXHAUSTED and a retry delay in the trailing metadata "
          "x-oaipp-retry-after-ms, so a fleet taking off together leaves over several seconds "
          "with whole first plans; 0: no pacing");
ABSL_FLAG(double, take_off_patience_s, 5.0,
          "take-off pacing: a UAV whose first take-off request was refused this many seconds "
          "ago is no longer held back by the queue rule (as many plans waiting as planning "
          "threads; --max_take_off_plans still holds), so that a steady replan load cannot keep "
          "the last of a fleet on the ground; "
          ">= 0, 0: the queue rule holds only the first request");
ABSL_FLAG(int, max_missions_per_tenant, 0, "missions one tenant may hold; 0: only --max_missions");
ABSL_FLAG(int64_t, max_memory_mb, 0,
          "memory all missions together may need (admission control, estimated from each spec "
          "before anything is allocated); 0: half of this machine's memory");
ABSL_FLAG(int64_t, max_mission_memory_mb, 4096, "memory one mission may need (see max_memory_mb)");
ABSL_FLAG(std::string, tls_cert, "", "PEM server certificate (chain); with --tls_key turns TLS on");
ABSL_FLAG(std::string, tls_key, "", "PEM private key of --tls_cert");
ABSL_FLAG(std::string, tls_client_ca, "",
          "PEM CA bundle: clients must present a certificate it signed (mutual TLS)");
ABSL_FLAG(bool, allow_insecure_remote, false,
          "listen on a non-loopback address without TLS (calls and tokens cross the network in "
          "the clear)");
ABSL_FLAG(std::string, token_file, "",
          "bearer tokens: lines '<tenant> <sha256 hex of token>'; callers must send "
          "'authorization: Bearer <token>' and see only their tenant's missions");
ABSL_FLAG(bool, reflection, true, "serve gRPC server reflection (for grpcurl and similar tools)");

namespace {

// Whether `address` (host:port, [v6]:port or unix:path) can be reached only
// from this machine.
bool IsLoopback(const std::string& address) {
  if (absl::StartsWith(address, "unix:") || absl::StartsWith(address, "unix-abstract:")) {
    return true;
  }
  std::string host = address.substr(0, address.rfind(':'));
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
    host = host.substr(1, host.size() - 2);
  }
  return host == "localhost" || host == "::1" || absl::StartsWith(host, "127.");
}

absl::StatusOr<std::string> ReadFile(const std::string& flag, const std::string& path) {
  std::ifstream in(path);
  if (!in) return absl::InvalidArgumentError(absl::StrCat(flag, ": cannot read '", path, "'"));
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The listening credentials the TLS flags ask for; InvalidArgument for an
// incomplete or unreadable set.
absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> ServerCredentials() {
  const std::string cert = absl::GetFlag(FLAGS_tls_cert);
  const std::string key = absl::GetFlag(FLAGS_tls_key);
  const std::string client_ca = absl::GetFlag(FLAGS_tls_client_ca);
  if (cert.empty() && key.empty()) {
    if (!client_ca.empty()) {
      return absl::InvalidArgumentError("--tls_client_ca needs --tls_cert and --tls_key");
    }
    return grpc::InsecureServerCredentials();
  }
  if (cert.empty() || key.empty()) {
    return absl::InvalidArgumentError("--tls_cert and --tls_key go together");
  }
  grpc::SslServerCredentialsOptions options(
      client_ca.empty() ? GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE
                        : GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY);
  grpc::SslServerCredentialsOptions::PemKeyCertPair pair;
  absl::StatusOr<std::string> cert_pem = ReadFile("--tls_cert", cert);
  if (!cert_pem.ok()) return cert_pem.status();
  absl::StatusOr<std::string> key_pem = ReadFile("--tls_key", key);
  if (!key_pem.ok()) return key_pem.status();
  pair.cert_chain = *cert_pem;
  pair.private_key = *key_pem;
  options.pem_key_cert_pairs.push_back(std::move(pair));
  if (!client_ca.empty()) {
    absl::StatusOr<std::string> ca_pem = ReadFile("--tls_client_ca", client_ca);
    if (!ca_pem.ok()) return ca_pem.status();
    options.pem_root_certs = *ca_pem;
  }
  return grpc::SslServerCredentials(options);
}

// Takes gRPC's reflection plugin out of a server being built. Linking the
// reflection library registers the plugin by itself (a static
// initializer), so leaving out InitProtoReflectionServerBuilderPlugin does
// not turn reflection off; removing the plugin does.
class WithoutReflection final : public grpc::ServerBuilderOption {
 public:
  void UpdateArguments(grpc::ChannelArguments*) override {}
  void UpdatePlugins(std::vector<std::unique_ptr<grpc::ServerBuilderPlugin>>* plugins) override {
    std::erase_if(*plugins, [](const std::unique_ptr<grpc::ServerBuilderPlugin>& plugin) {
      return plugin->name() == "proto_server_reflection";
    });
  }
};

}  // namespace
ABSL_FLAG(int, snapshot_every, 16,
          "with a store: snapshot a mission's map and state after this many measurements (or 4x "
          "as many records) since its last one, so recovery replays at most that many; 0: never");
ABSL_FLAG(int, recovery_threads, 2, "threads that rebuild missions from the store at start");
ABSL_FLAG(absl::Duration, keep_finished, absl::Hours(7 * 24),
          "how long a mission whose flight budget is spent is kept after its last change, "
          "then deleted with its records ('inf': forever)");
ABSL_FLAG(absl::Duration, keep_idle, absl::Hours(30 * 24),
          "how long any mission is kept after its last change ('inf': forever)");
ABSL_FLAG(std::string, replica_id, "",
          "a name for this server, sent back on every call as the x-oaipp-replica header "
          "(which replica of a cluster answered); empty: not sent");
ABSL_FLAG(bool, cluster, false,
          "this server is one of several replicas sharing a PostgreSQL --store behind a proxy "
          "that routes by the x-oaipp-mission header: it loads no mission at start, takes a "
          "mission over from the store when a call for it arrives, and drops a mission another "
          "replica has taken (docs/cluster.md)");

ABSL_FLAG(int, web_port, 0,
          "port of the live mission view, a read-only web page (docs/ground-stations.md); "
          "0: off");
ABSL_FLAG(std::string, web_address, "127.0.0.1",
          "address the live view binds; beyond loopback only with --token_file (each request "
          "then names a token and sees its tenant's missions)");

int main(int argc, char** argv) {
  // OpenBLAS picks its kernels when it is loaded, with the program.
  oaipp::server::RestartWithOpenBlasKernels(argv);
  absl::SetProgramUsageMessage("OA-IPP planning service (oaipp.v1.MissionService)");
  absl::ParseCommandLine(argc, argv);
  spdlog::set_level(spdlog::level::from_str(absl::GetFlag(FLAGS_log_level)));
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");
  // Protobuf writes a line to stderr for every request it cannot parse (a
  // string field that is not UTF-8, say), so any client could flood the
  // log; the caller is told by its status, and the line becomes debug.
  google::protobuf::SetLogHandler(
      [](google::protobuf::LogLevel, const char*, int, const std::string& message) {
        spdlog::debug("protobuf: {}", message.substr(0, 200));
      });

  // Before any thread starts: loading OpenBLAS may set its environment.
  if (const std::string backend = absl::GetFlag(FLAGS_dense_backend); backend == "openblas") {
    if (absl::Status loaded = oaipp::UseOpenBlas(); !loaded.ok()) {
      spdlog::warn("{}", std::string(loaded.message()));
    }
  } else if (backend != "eigen") {
    spdlog::error("bad flags: dense_backend must be openblas or eigen");
    return 2;
  }
  if (absl::Status set = oaipp::SetObjectivePrecision(absl::GetFlag(FLAGS_objective_precision));
      !set.ok()) {
    spdlog::error("bad flags: {}", std::string(set.message()));
    return 2;
  }
  spdlog::info("Kalman update on {}; adaptive objective's solves in {} precision",
               oaipp::DenseBackendName(), absl::GetFlag(FLAGS_objective_precision));

  // SIGTERM and SIGINT drain the server from here on, whichever thread
  // receives them (server/stop_signals.h says why a mask is not enough).
  absl::StatusOr<oaipp::server::StopSignals> stop_signals = oaipp::server::StopSignals::Install();
  if (!stop_signals.ok()) {
    spdlog::error("{}", std::string(stop_signals.status().message()));
    return 1;
  }

  const int threads = absl::GetFlag(FLAGS_worker_threads);
  const int planning_threads = absl::GetFlag(FLAGS_planning_threads);
  const int planning_queue = absl::GetFlag(FLAGS_planning_queue);
  const int planning_nice = absl::GetFlag(FLAGS_planning_nice);
  if (threads < 2 || planning_threads < 1 || planning_queue < 0 || planning_nice < 0 ||
      planning_nice > 19 || absl::GetFlag(FLAGS_max_missions) < 1 ||
      absl::GetFlag(FLAGS_max_cells) < 1 || absl::GetFlag(FLAGS_snapshot_every) < 0 ||
      absl::GetFlag(FLAGS_recovery_threads) < 1 ||
      absl::GetFlag(FLAGS_keep_finished) <= absl::ZeroDuration() ||
      absl::GetFlag(FLAGS_keep_idle) <= absl::ZeroDuration() ||
      absl::GetFlag(FLAGS_prior_cache) < 0 || absl::GetFlag(FLAGS_max_streams) < 1 ||
      absl::GetFlag(FLAGS_max_streams_per_client) < 1 ||
      absl::GetFlag(FLAGS_max_plans_per_tenant) < 0 ||
      absl::GetFlag(FLAGS_max_take_off_plans) < 0 ||
      !(absl::GetFlag(FLAGS_take_off_patience_s) >= 0 &&
        absl::GetFlag(FLAGS_take_off_patience_s) < 1e6) ||
      !(absl::GetFlag(FLAGS_max_planning_s) > 0 && absl::GetFlag(FLAGS_max_planning_s) < 1e6) ||
      absl::GetFlag(FLAGS_max_missions_per_tenant) < 0 || absl::GetFlag(FLAGS_max_memory_mb) < 0 ||
      absl::GetFlag(FLAGS_max_mission_memory_mb) < 0 ||
      !(absl::GetFlag(FLAGS_shed_above) >= 0 && absl::GetFlag(FLAGS_shed_above) < 1e6) ||
      !(absl::GetFlag(FLAGS_min_search_fraction) > 0 &&
        absl::GetFlag(FLAGS_min_search_fraction) <= 1) ||
      !(absl::GetFlag(FLAGS_plan_latency_s) >= 0 && absl::GetFlag(FLAGS_plan_latency_s) < 1e6)) {
    spdlog::error(
        "bad flags: need worker_threads >= 2, planning_threads >= 1, "
        "planning_queue >= 0, 0 <= planning_nice <= 19, max_missions >= 1, max_cells >= 1, "
        "prior_cache >= 0, "
        "snapshot_every >= 0, recovery_threads >= 1, keep_finished > 0, keep_idle > 0, "
        "max_streams >= 1, max_streams_per_client >= 1, 0 < max_planning_s < 1e6, and the quotas, "
        "max_take_off_plans and memory limits >= 0, 0 <= shed_above < 1e6, "
        "0 < min_search_fraction <= 1, 0 <= plan_latency_s < 1e6, "
        "0 <= take_off_patience_s < 1e6");
    return 2;
  }
  absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> credentials = ServerCredentials();
  if (!credentials.ok()) {
    spdlog::error("{}", std::string(credentials.status().message()));
    return 2;
  }
  const bool tls = !absl::GetFlag(FLAGS_tls_cert).empty();
  if (!tls && !IsLoopback(absl::GetFlag(FLAGS_listen)) &&
      !absl::GetFlag(FLAGS_allow_insecure_remote)) {
    spdlog::error(
        "--listen={} is not a loopback address and TLS is off: give --tls_cert and --tls_key, or "
        "--allow_insecure_remote to serve in the clear",
        absl::GetFlag(FLAGS_listen));
    return 2;
  }
  oaipp::server::Authenticator auth;
  if (const std::string path = absl::GetFlag(FLAGS_token_file); !path.empty()) {
    absl::StatusOr<oaipp::server::Authenticator> loaded =
        oaipp::server::Authenticator::FromFile(path);
    if (!loaded.ok()) {
      spdlog::error("--token_file: {}", std::string(loaded.status().message()));
      return 2;
    }
    auth = *std::move(loaded);
    spdlog::info("auth: {} tenants from {}", auth.tenants(), path);
  }
  std::int64_t max_memory = absl::GetFlag(FLAGS_max_memory_mb) << 20;
  if (max_memory == 0) {
    max_memory = static_cast<std::int64_t>(sysconf(_SC_PHYS_PAGES)) * sysconf(_SC_PAGE_SIZE) / 2;
  }

  const std::string replica_id = absl::GetFlag(FLAGS_replica_id);
  if (replica_id.size() > 64 || !std::all_of(replica_id.begin(), replica_id.end(), [](char c) {
        return absl::ascii_isalnum(c) || c == '-' || c == '_' || c == '.' || c == ':';
      })) {
    spdlog::error("--replica_id: at most 64 letters, digits, '-', '_', '.' or ':'");
    return 2;
  }
  const bool cluster = absl::GetFlag(FLAGS_cluster);
  if (cluster && !absl::StartsWith(absl::GetFlag(FLAGS_store), "postgres")) {
    spdlog::error("--cluster needs a store the replicas share: --store=postgresql://...");
    return 2;
  }
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
       .recovery_threads = absl::GetFlag(FLAGS_recovery_threads),
       .max_missions_per_tenant = absl::GetFlag(FLAGS_max_missions_per_tenant),
       .max_mission_memory_bytes = absl::GetFlag(FLAGS_max_mission_memory_mb) << 20,
       .max_memory_bytes = max_memory,
       .shared_store = cluster},
      store.get());
  {
    const absl::Time started = absl::Now();
    absl::StatusOr<int> recovered = registry.Recover();
    if (!recovered.ok()) {
      spdlog::error("store: {}", recovered.status().ToString());
      return 1;
    }
    if (cluster) {
      spdlog::info("cluster: missions are taken over from the store as calls for them arrive");
    } else if (store != nullptr) {
      spdlog::info("store: recovered {} missions in {:.3f} s", *recovered,
                   absl::ToDoubleSeconds(absl::Now() - started));
    }
  }
  oaipp::server::PlanningPool planners(planning_threads, planning_queue, planning_nice);
  oaipp::server::Metrics metrics;
  oaipp::server::MetricsHttp metrics_http(metrics.registry());
  std::string metrics_at = "-";
  if (const std::string address = absl::GetFlag(FLAGS_metrics_listen); !address.empty()) {
    if (const absl::Status st = metrics_http.Start(address); !st.ok()) {
      spdlog::error("{}", std::string(st.message()));
      return 1;
    }
    metrics_at = metrics_http.address();
  }
  oaipp::server::MissionServiceImpl service(
      &registry, &planners, &metrics, &auth,
      {.max_streams = absl::GetFlag(FLAGS_max_streams),
       .max_streams_per_client = absl::GetFlag(FLAGS_max_streams_per_client),
       .max_plans_per_tenant = absl::GetFlag(FLAGS_max_plans_per_tenant),
       .max_planning = absl::Seconds(absl::GetFlag(FLAGS_max_planning_s)),
       .shed_above = absl::GetFlag(FLAGS_shed_above),
       .min_search_fraction = absl::GetFlag(FLAGS_min_search_fraction),
       .plan_latency = absl::Seconds(absl::GetFlag(FLAGS_plan_latency_s)),
       .max_take_off_plans = absl::GetFlag(FLAGS_max_take_off_plans),
       .take_off_patience = absl::Seconds(absl::GetFlag(FLAGS_take_off_patience_s)),
       .replica_id = absl::GetFlag(FLAGS_replica_id)});

  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  if (!absl::GetFlag(FLAGS_reflection)) builder.SetOption(std::make_unique<WithoutReflection>());
  int port = 0;
  builder.AddListeningPort(absl::GetFlag(FLAGS_listen), *credentials, &port);
  grpc::ResourceQuota quota("oaipp-server");
  quota.SetMaxThreads(threads);
  builder.SetResourceQuota(quota);
  builder.SetMaxReceiveMessageSize(static_cast<int>(oaipp::api::kMaxMessageBytes));
  builder.SetMaxSendMessageSize(static_cast<int>(oaipp::api::kMaxMessageBytes));
  // Idle serving threads wake up this often; it bounds how long shutdown
  // waits for them once the last call has finished.
  builder.SetSyncServerOption(grpc::ServerBuilder::SyncServerOption::CQ_TIMEOUT_MSEC, 200);
  builder.RegisterService(&service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (server == nullptr || port == 0) {
    spdlog::error("cannot listen on {}", absl::GetFlag(FLAGS_listen));
    return 1;
  }
  oaipp::server::WebView web_view(&registry, &auth);
  if (const int web_port = absl::GetFlag(FLAGS_web_port); web_port != 0) {
    if (web_port < 0 || web_port > 65535) {
      spdlog::error("web_port: must be in [0, 65535], got {}", web_port);
      return 1;
    }
    if (absl::Status started = web_view.Start(absl::GetFlag(FLAGS_web_address), web_port);
        !started.ok()) {
      spdlog::error("{}", std::string(started.message()));
      return 1;
    }
  }
  server->GetHealthCheckService()->SetServingStatus("oaipp.v1.MissionService", true);
  server->GetHealthCheckService()->SetServingStatus(true);
  spdlog::info("oaipp-server listening on {} ({}{}; metrics on {})", absl::GetFlag(FLAGS_listen),
               tls ? "TLS" : "plaintext",
               absl::GetFlag(FLAGS_tls_client_ca).empty() ? "" : ", mutual", metrics_at);

  // Health follows the store and the load: NOT_SERVING while the store
  // cannot be written (the disk gone or full) or while new plans or streams
  // would be refused, so that a balancer sends calls elsewhere. The store is
  // probed every second, the load four times a second.
  absl::Notification stopping;
  std::thread store_watch([&] {
    bool store_ok = true;
    bool overloaded = false;
    bool serving = true;
    int tick = 0;
    while (!stopping.WaitForNotificationWithTimeout(absl::Milliseconds(250))) {
      if (store != nullptr && tick++ % 4 == 0) {
        const absl::Status status = store->Health();
        if (status.ok() != store_ok) {
          store_ok = status.ok();
          if (store_ok) {
            spdlog::info("store: writable again");
          } else {
            spdlog::warn("store: {}", status.ToString());
          }
        }
      }
      // A cluster's replica lets go of missions another replica took over
      // while it was not looking (every 5 s).
      if (cluster && tick % 20 == 1) registry.DropMoved();
      if (service.Overloaded() != overloaded) {
        overloaded = !overloaded;
        spdlog::warn("load: {}", overloaded ? "overloaded (planners and queue full, or every "
                                              "stream taken)"
                                            : "back under the limits");
      }
      if ((store_ok && !overloaded) != serving) {
        serving = !serving;
        spdlog::info("health: {}", serving ? "SERVING" : "NOT_SERVING");
        server->GetHealthCheckService()->SetServingStatus("oaipp.v1.MissionService", serving);
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
    const int signal = stop_signals->Wait();
    spdlog::info("signal {}: no new calls; finishing the ones in flight", signal);
    stopping.Notify();
    server->GetHealthCheckService()->SetServingStatus(false);
    const auto grace = std::chrono::milliseconds(
        static_cast<int64_t>(absl::GetFlag(FLAGS_shutdown_grace_s) * 1000));
    server->Shutdown(std::chrono::system_clock::now() + grace);
  });
  server->Wait();
  web_view.Stop();
  // Snapshots already asked for are written, so that the next start replays
  // short tails.
  registry.FlushSnapshots();
  waiter.join();
  store_watch.join();
  sweeper.join();
  spdlog::info("oaipp-server stopped");
  return 0;
}
