// A whole server assembled from its ServerOptions: the mission store (and
// the missions it recovers), the registry, the planning pool, metrics and
// their HTTP endpoint, the gRPC service with its credentials and tenants,
// the live web view, and the two background loops (health follows the
// store and the load; retention expires old missions). oaipp-server's
// main(), the benchmarks and the tests' in-process fixtures build their
// servers with it; a fixture gives its parts (limits, a store of its own, a
// manual clock) as ServerParts instead of flags.
//
//   absl::StatusOr<std::unique_ptr<Server>> server = Server::Start(options);
//   if (!server.ok()) ...                   // InvalidArgument: a bad setting
//   ... (*server)->port() ...
//   (*server)->Shutdown(absl::Seconds(10));  // drains in-flight calls
#pragma once

#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/notification.h"
#include "absl/time/time.h"
#include "core/mapping/dense_backend.h"
#include "grpcpp/grpcpp.h"
#include "grpcpp/support/server_interceptor.h"
#include "server/auth.h"
#include "server/metrics.h"
#include "server/metrics_http.h"
#include "server/planning_pool.h"
#include "server/registry.h"
#include "server/server_options.h"
#include "server/service.h"
#include "server/store/mission_store.h"
#include "server/web_view.h"

namespace oaipp::server {

// What Server::Start(options) makes of the options (the store opened, the
// tenants loaded, the dense backend loaded, the limits in their units), or
// what a program that embeds a server gives directly.
struct ServerParts {
  RegistryLimits registry = {};
  ServiceLimits service = {};
  int planning_threads = 2;
  int planning_queue = 64;
  int planning_nice = 0;
  // Borrowed, and must outlive the server; nullptr: nothing persists.
  MissionStore* store = nullptr;
  // Borrowed, and must outlive the server; nullptr: no tenants.
  const Authenticator* auth = nullptr;
  // Run on every call before the service (a program's own logging, or a
  // test's fault injection); none by default.
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> interceptors =
      {};
};

class Server {
 public:
  // Checks the options, opens the store, recovers its missions (none with
  // --cluster), starts the planners, the metrics endpoint, the gRPC server
  // and the web view, and reports SERVING. InvalidArgument names the
  // setting at fault; other errors (a store that cannot be opened, a port
  // in use) keep their own codes. Nothing keeps running after an error.
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<Server>> Start(const ServerOptions& options);

  // The same server from `parts` instead of the options' store, tenants,
  // limits and planning pool; the options give the rest: the listening
  // address and its TLS (an empty `listen` serves only InProcessChannel()),
  // reflection, metrics, the web view, worker threads, retention and the
  // cluster's health loop. The options are not validated (the parts have no
  // flags to name). Errors as Start.
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<Server>> Start(const ServerOptions& options,
                                                                     ServerParts parts);

  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;
  // Shutdown(zero grace) unless it ran.
  ~Server();

  // Stops taking calls (health NOT_SERVING), lets calls in flight finish for
  // up to `grace`, then cancels the rest, stops the web view, writes the
  // snapshots already asked for and stops the background loops. Idempotent.
  void Shutdown(absl::Duration grace);

  // The gRPC port as bound ("127.0.0.1:0" binds any free one).
  [[nodiscard]] int port() const { return port_; }
  // The metrics endpoint's host:port, or "-" when off.
  [[nodiscard]] const std::string& metrics_address() const { return metrics_at_; }
  [[nodiscard]] MissionRegistry& registry() { return *registry_; }
  // Where the missions' dense products run (--dense_backend).
  [[nodiscard]] const DenseBackend& dense_backend() const { return dense_backend_; }
  [[nodiscard]] MissionServiceImpl& service() { return *service_; }
  [[nodiscard]] PlanningPool& planners() { return *planners_; }
  // How many missions the start recovered from the store, or why it could
  // not (then Start failed).
  [[nodiscard]] const absl::StatusOr<int>& recovered() const { return recovered_; }
  // A channel to this server inside the process (no socket).
  [[nodiscard]] std::shared_ptr<grpc::Channel> InProcessChannel();

 private:
  explicit Server(ServerOptions options) : options_(std::move(options)) {}
  // Opens the store (owned), loads the tenants and the dense backend.
  absl::StatusOr<ServerParts> PartsFromOptions();
  // Builds and starts everything from the parts and the options.
  absl::Status Assemble(ServerParts parts);
  // Health follows the store and the load; a cluster's replica drops the
  // missions others took over.
  void WatchHealth();
  // Expires finished and idle missions.
  void SweepRetention();
  // A cluster's replica tells the store it is alive, five times per
  // RegistryLimits::silent_after.
  void Heartbeat();
  // A replica on the proxies' ring keeps its warm standbys up to date
  // (MissionRegistry::KeepStandbys) twice per silent_after.
  void KeepStandbys();

  const ServerOptions options_;
  Authenticator auth_;
  DenseBackend dense_backend_;
  std::unique_ptr<MissionStore> owned_store_;  // the options' store
  MissionStore* store_ = nullptr;
  absl::StatusOr<int> recovered_ = 0;
  std::unique_ptr<MissionRegistry> registry_;
  std::unique_ptr<PlanningPool> planners_;
  Metrics metrics_;
  std::unique_ptr<MetricsHttp> metrics_http_;
  std::string metrics_at_ = "-";
  std::unique_ptr<MissionServiceImpl> service_;
  std::unique_ptr<grpc::Server> grpc_;
  int port_ = 0;
  std::unique_ptr<WebView> web_view_;
  absl::Notification stopping_;
  std::thread health_watch_;
  std::thread sweeper_;
  std::thread heartbeat_;
  std::thread standby_;
  // Who this server is in the store's leases (RegistryLimits::holder).
  std::string holder_;
  absl::Duration silent_after_;
  bool shut_down_ = false;
};

}  // namespace oaipp::server
