#include "server/server.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <sstream>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "api/limits.h"
#include "core/mapping/dense_backend.h"
#include "grpcpp/ext/proto_server_reflection_plugin.h"
#include "grpcpp/health_check_service_interface.h"
#include "grpcpp/impl/server_builder_option.h"
#include "grpcpp/impl/server_builder_plugin.h"
#include "server/store/open_store.h"
#include "spdlog/spdlog.h"

namespace oaipp::server {
namespace {

constexpr char kServiceName[] = "oaipp.v1.MissionService";

absl::StatusOr<std::string> ReadFile(const std::string& flag, const std::string& path) {
  std::ifstream in(path);
  if (!in) return absl::InvalidArgumentError(absl::StrCat(flag, ": cannot read '", path, "'"));
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The listening credentials the TLS settings ask for (Validate has checked
// that they come as a set); InvalidArgument for an unreadable file.
absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> Credentials(const ServerOptions& o) {
  if (o.tls_cert.empty()) return grpc::InsecureServerCredentials();
  grpc::SslServerCredentialsOptions ssl(
      o.tls_client_ca.empty() ? GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE
                              : GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY);
  grpc::SslServerCredentialsOptions::PemKeyCertPair pair;
  absl::StatusOr<std::string> cert = ReadFile("--tls_cert", o.tls_cert);
  if (!cert.ok()) return cert.status();
  absl::StatusOr<std::string> key = ReadFile("--tls_key", o.tls_key);
  if (!key.ok()) return key.status();
  pair.cert_chain = *std::move(cert);
  pair.private_key = *std::move(key);
  ssl.pem_key_cert_pairs.push_back(std::move(pair));
  if (!o.tls_client_ca.empty()) {
    absl::StatusOr<std::string> ca = ReadFile("--tls_client_ca", o.tls_client_ca);
    if (!ca.ok()) return ca.status();
    ssl.pem_root_certs = *std::move(ca);
  }
  return grpc::SslServerCredentials(ssl);
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

// The dense backend --dense_backend names: OpenBLAS when asked for and
// loadable (a failure to load it is logged and Eigen kept), else Eigen.
DenseBackend ChooseDenseBackend(const ServerOptions& options) {
  DenseBackend backend;
  if (options.dense_backend == "openblas") {
    absl::StatusOr<DenseBackend> blas = DenseBackend::OpenBlas();
    if (blas.ok()) {
      backend = *blas;
    } else {
      spdlog::warn("{}", std::string(blas.status().message()));
    }
  }
  spdlog::info("Kalman update and objective on {}; adaptive objective's solves in {} precision",
               backend.name(), options.objective_precision);
  return backend;
}

absl::StatusOr<std::unique_ptr<Server>> Server::Start(const ServerOptions& options) {
  if (absl::Status valid = options.Validate(); !valid.ok()) return valid;
  // Planners, the Kalman update and the sparse map call the BLAS from many
  // threads at once.
  if (absl::Status safe = CheckBlasIsSafeForConcurrentCalls(); !safe.ok()) return safe;
  std::unique_ptr<Server> server(new Server(options));
  absl::StatusOr<ServerParts> parts = server->PartsFromOptions();
  absl::Status started = parts.ok() ? server->Assemble(*std::move(parts)) : parts.status();
  if (!started.ok()) {
    server->Shutdown(absl::ZeroDuration());
    return started;
  }
  return server;
}

absl::StatusOr<std::unique_ptr<Server>> Server::Start(const ServerOptions& options,
                                                      ServerParts parts) {
  std::unique_ptr<Server> server(new Server(options));
  if (absl::Status started = server->Assemble(std::move(parts)); !started.ok()) {
    server->Shutdown(absl::ZeroDuration());
    return started;
  }
  return server;
}

absl::StatusOr<ServerParts> Server::PartsFromOptions() {
  const ServerOptions& o = options_;
  if (!o.token_file.empty()) {
    absl::StatusOr<Authenticator> loaded = Authenticator::FromFile(o.token_file);
    if (!loaded.ok()) {
      return absl::InvalidArgumentError(absl::StrCat("--token_file: ", loaded.status().message()));
    }
    auth_ = *std::move(loaded);
    spdlog::info("auth: {} tenants from {}", auth_.tenants(), o.token_file);
  }
  std::int64_t max_memory = o.max_memory_mb << 20;
  if (max_memory == 0) {
    max_memory = static_cast<std::int64_t>(sysconf(_SC_PHYS_PAGES)) * sysconf(_SC_PAGE_SIZE) / 2;
  }
  absl::StatusOr<std::unique_ptr<MissionStore>> opened = OpenStore(o.store, o.data_dir);
  if (!opened.ok()) return opened.status();
  owned_store_ = *std::move(opened);
  spdlog::info("store: {}", DescribeStore(o.store, o.data_dir));
  return ServerParts{.registry = {.max_missions = o.max_missions,
                                  .max_cells_per_mission = o.max_cells,
                                  .max_dense_cells = o.max_dense_cells,
                                  .prior_cache = o.prior_cache,
                                  .snapshot_every = o.snapshot_every,
                                  .recovery_threads = o.recovery_threads,
                                  .max_missions_per_tenant = o.max_missions_per_tenant,
                                  .max_mission_memory_bytes = o.max_mission_memory_mb << 20,
                                  .max_memory_bytes = max_memory,
                                  .shared_store = o.cluster,
                                  .holder = o.replica_id,
                                  // A waiting replica waits up to silent_after for the
                                  // holder to fall silent: the lease, renewed every quarter of
                                  // it, must outlast that wait.
                                  .mission_lease = 4 * o.silent_after,
                                  .silent_after = o.silent_after,
                                  .ring_id = o.EffectiveRingId(),
                                  .max_standbys = o.standby_missions,
                                  .single_precision_objective = o.objective_precision == "single",
                                  .dense_backend = ChooseDenseBackend(o)},
                     .service = {.max_streams = o.max_streams,
                                 .max_streams_per_client = o.max_streams_per_client,
                                 .max_plans_per_tenant = o.max_plans_per_tenant,
                                 .max_planning = absl::Seconds(o.max_planning_s),
                                 .shed_above = o.shed_above,
                                 .min_search_fraction = o.min_search_fraction,
                                 .shed_after_wait = absl::Seconds(o.shed_after_wait_s),
                                 .plan_latency = absl::Seconds(o.plan_latency_s),
                                 .max_take_off_plans = o.max_take_off_plans,
                                 .take_off_patience = absl::Seconds(o.take_off_patience_s),
                                 .replica_id = o.replica_id},
                     .planning_threads = o.planning_threads,
                     .planning_queue = o.planning_queue,
                     .planning_nice = o.planning_nice,
                     .store = owned_store_.get(),
                     .auth = &auth_};
}

absl::Status Server::Assemble(ServerParts parts) {
  const ServerOptions& o = options_;
  store_ = parts.store;
  dense_backend_ = parts.registry.dense_backend;
  if (parts.registry.holder.empty()) {
    parts.registry.holder = absl::StrCat("pid-", getpid(), "-", absl::ToUnixNanos(absl::Now()));
  }
  holder_ = parts.registry.holder;
  silent_after_ = parts.registry.silent_after;
  if (parts.registry.shared_store && store_ != nullptr) {
    // Alive before the first call can take a mission over.
    if (absl::Status alive = store_->Heartbeat(
            holder_, absl::ToUnixMicros(absl::Now() + silent_after_), o.EffectiveRingId());
        !alive.ok()) {
      return absl::Status(alive.code(), absl::StrCat("store: ", alive.message()));
    }
    heartbeat_ = std::thread([this] { Heartbeat(); });
  }
  registry_ = std::make_unique<MissionRegistry>(parts.registry, store_);
  const absl::Time recovery_started = absl::Now();
  recovered_ = registry_->Recover();
  if (!recovered_.ok()) {
    return absl::Status(recovered_.status().code(),
                        absl::StrCat("store: ", recovered_.status().message()));
  }
  if (parts.registry.shared_store) {
    spdlog::info("cluster: missions are taken over from the store as calls for them arrive");
  } else if (store_ != nullptr) {
    spdlog::info("store: recovered {} missions in {:.3f} s", *recovered_,
                 absl::ToDoubleSeconds(absl::Now() - recovery_started));
  }

  planners_ = std::make_unique<PlanningPool>(parts.planning_threads, parts.planning_queue,
                                             parts.planning_nice);
  metrics_http_ = std::make_unique<MetricsHttp>(metrics_.registry());
  if (!o.metrics_listen.empty()) {
    if (absl::Status st = metrics_http_->Start(o.metrics_listen); !st.ok()) return st;
    metrics_at_ = metrics_http_->address();
  }
  service_ = std::make_unique<MissionServiceImpl>(registry_.get(), planners_.get(), &metrics_,
                                                  parts.auth, parts.service);

  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  if (!o.reflection) builder.SetOption(std::make_unique<WithoutReflection>());
  if (!o.listen.empty()) {
    absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> credentials = Credentials(o);
    if (!credentials.ok()) return credentials.status();
    // Under TLS a bad token is refused before the request is read.
    if (parts.auth != nullptr && parts.auth->enabled() && !o.tls_cert.empty()) {
      (*credentials)->SetAuthMetadataProcessor(std::make_shared<TokenCheck>(parts.auth));
    }
    builder.AddListeningPort(o.listen, *credentials, &port_);
  }
  grpc::ResourceQuota quota("oaipp-server");
  quota.SetMaxThreads(o.worker_threads);
  builder.SetResourceQuota(quota);
  builder.SetMaxReceiveMessageSize(static_cast<int>(api::kMaxMessageBytes));
  builder.SetMaxSendMessageSize(static_cast<int>(api::kMaxMessageBytes));
  // Idle serving threads wake up this often; it bounds how long shutdown
  // waits for them once the last call has finished.
  builder.SetSyncServerOption(grpc::ServerBuilder::SyncServerOption::CQ_TIMEOUT_MSEC, 200);
  builder.RegisterService(service_.get());
  if (!parts.interceptors.empty()) {
    builder.experimental().SetInterceptorCreators(std::move(parts.interceptors));
  }
  grpc_ = builder.BuildAndStart();
  if (grpc_ == nullptr || (!o.listen.empty() && port_ == 0)) {
    return absl::UnavailableError(absl::StrCat("--listen: cannot listen on ", o.listen));
  }
  web_view_ = std::make_unique<WebView>(registry_.get(), parts.auth);
  if (o.web_port != 0) {
    WebViewOptions view{.address = o.web_address,
                        .port = o.web_port,
                        .tls_cert = o.tls_cert,
                        .tls_key = o.tls_key,
                        .host_names = absl::StrSplit(o.web_hosts, ',', absl::SkipWhitespace())};
    if (absl::Status started = web_view_->Start(view); !started.ok()) {
      return started;
    }
  }
  grpc_->GetHealthCheckService()->SetServingStatus(kServiceName, true);
  grpc_->GetHealthCheckService()->SetServingStatus(true);
  spdlog::info("oaipp-server listening on {} ({}{}; metrics on {})",
               o.listen.empty() ? "nothing (in process only)" : o.listen,
               o.tls_cert.empty() ? "plaintext" : "TLS", o.tls_client_ca.empty() ? "" : ", mutual",
               metrics_at_);
  health_watch_ = std::thread([this] { WatchHealth(); });
  sweeper_ = std::thread([this] { SweepRetention(); });
  if (parts.registry.shared_store && parts.registry.ring_id > 0 &&
      parts.registry.max_standbys > 0) {
    standby_ = std::thread([this] { KeepStandbys(); });
  }
  return absl::OkStatus();
}

// Health follows the store and the load: NOT_SERVING while the store cannot
// be written (the disk gone or full) or while new plans or streams would be
// refused, so that a balancer sends calls elsewhere. The store is probed
// every second, the load four times a second.
void Server::WatchHealth() {
  bool store_ok = true;
  bool overloaded = false;
  bool serving = true;
  int tick = 0;
  while (!stopping_.WaitForNotificationWithTimeout(absl::Milliseconds(250))) {
    if (store_ != nullptr && tick++ % 4 == 0) {
      const absl::Status status = store_->Health();
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
    if (options_.cluster && tick % 20 == 1) registry_->DropMoved();
    if (service_->Overloaded() != overloaded) {
      overloaded = !overloaded;
      spdlog::warn("load: {}", overloaded ? "overloaded (planners and queue full, or every "
                                            "stream taken)"
                                          : "back under the limits");
    }
    if ((store_ok && !overloaded) != serving) {
      serving = !serving;
      spdlog::info("health: {}", serving ? "SERVING" : "NOT_SERVING");
      grpc_->GetHealthCheckService()->SetServingStatus(kServiceName, serving);
    }
  }
}

void Server::SweepRetention() {
  const absl::Duration every = std::clamp(std::min(options_.keep_finished, options_.keep_idle) / 10,
                                          absl::Seconds(1), absl::Minutes(1));
  // A cluster's replicas also sweep the shared store, one at a time: the
  // holder of the store's lease renews it at each sweep; it lapses three
  // sweeps after its holder stops, and another replica takes it.
  while (!stopping_.WaitForNotificationWithTimeout(every)) {
    const absl::Time now = absl::Now();
    for (const std::string& id :
         registry_->Sweep(now, options_.keep_finished, options_.keep_idle)) {
      spdlog::info("mission event=expired name=missions/{}", id);
    }
    for (const std::string& id :
         registry_->SweepStore(now, options_.keep_idle, holder_, 3 * every)) {
      spdlog::info("mission event=expired name=missions/{} (from the shared store)", id);
    }
  }
}

void Server::KeepStandbys() {
  // Twice per silent_after (250 ms with the defaults): what a standby lacks
  // when its holder dies is the records of its holder's last 250 ms.
  while (!stopping_.WaitForNotificationWithTimeout(silent_after_ / 2)) {
    registry_->KeepStandbys();
  }
}

void Server::Heartbeat() {
  bool ok = true;
  while (!stopping_.WaitForNotificationWithTimeout(silent_after_ / 5)) {
    const absl::Status alive = store_->Heartbeat(
        holder_, absl::ToUnixMicros(absl::Now() + silent_after_), options_.EffectiveRingId());
    if (alive.ok() != ok) {
      ok = alive.ok();
      if (ok) {
        spdlog::info("cluster: heartbeats reach the store again");
      } else {
        spdlog::warn("cluster: heartbeat: {} (other replicas may take this one's missions)",
                     alive.ToString());
      }
    }
  }
}

std::shared_ptr<grpc::Channel> Server::InProcessChannel() {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(static_cast<int>(api::kMaxMessageBytes));
  args.SetMaxSendMessageSize(static_cast<int>(api::kMaxMessageBytes));
  return grpc_->InProcessChannel(args);
}

void Server::Shutdown(absl::Duration grace) {
  if (shut_down_) return;
  shut_down_ = true;
  if (!stopping_.HasBeenNotified()) stopping_.Notify();
  if (grpc_ != nullptr) {
    grpc_->GetHealthCheckService()->SetServingStatus(false);
    grpc_->Shutdown(std::chrono::system_clock::now() + absl::ToChronoMilliseconds(grace));
    grpc_->Wait();
  }
  if (web_view_ != nullptr) web_view_->Stop();
  // Snapshots already asked for are written, so that the next start replays
  // short tails.
  if (registry_ != nullptr) registry_->FlushSnapshots();
  if (health_watch_.joinable()) health_watch_.join();
  if (sweeper_.joinable()) sweeper_.join();
  if (standby_.joinable()) standby_.join();
  if (heartbeat_.joinable()) {
    heartbeat_.join();
    // Gone: the other replicas take this one's missions at their next call,
    // without waiting for it to fall silent.
    if (absl::Status retired = store_->Retire(holder_); !retired.ok()) {
      spdlog::warn("cluster: retiring from the store: {}", retired.ToString());
    }
  }
  if (metrics_http_ != nullptr) metrics_http_->Stop();
}

Server::~Server() { Shutdown(absl::ZeroDuration()); }

}  // namespace oaipp::server
