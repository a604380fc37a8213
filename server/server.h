// A whole server assembled from its ServerOptions: the mission store (and
// the missions it recovers), the registry, the planning pool, metrics and
// their HTTP endpoint, the gRPC service with its credentials and tenants,
// the live web view, and the two background loops (health follows the
// store and the load; retention expires old missions). oaipp-server's
// main() and the load benchmark build their servers with it.
//
//   absl::StatusOr<std::unique_ptr<Server>> server = Server::Start(options);
//   if (!server.ok()) ...                   // InvalidArgument: a bad setting
//   ... (*server)->port() ...
//   (*server)->Shutdown(absl::Seconds(10));  // drains in-flight calls
#pragma once

#include <memory>
#include <string>
#include <thread>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/notification.h"
#include "absl/time/time.h"
#include "grpcpp/grpcpp.h"
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

// What a process must set up once, before any server starts and before
// other threads run: the Kalman update's dense backend (OpenBLAS is loaded
// here; a failure to load it is logged and Eigen is kept) and the adaptive
// objective's precision. InvalidArgument for a bad value.
[[nodiscard]] absl::Status SetUpProcess(const ServerOptions& options);

class Server {
 public:
  // Checks the options, opens the store, recovers its missions (none with
  // --cluster), starts the planners, the metrics endpoint, the gRPC server
  // and the web view, and reports SERVING. InvalidArgument names the
  // setting at fault; other errors (a store that cannot be opened, a port
  // in use) keep their own codes. Nothing keeps running after an error.
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<Server>> Start(const ServerOptions& options);

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
  [[nodiscard]] MissionServiceImpl& service() { return *service_; }
  // A channel to this server inside the process (no socket).
  [[nodiscard]] std::shared_ptr<grpc::Channel> InProcessChannel();

 private:
  explicit Server(ServerOptions options) : options_(std::move(options)) {}
  absl::Status StartParts();
  // Health follows the store and the load; a cluster's replica drops the
  // missions others took over.
  void WatchHealth();
  // Expires finished and idle missions.
  void SweepRetention();

  const ServerOptions options_;
  Authenticator auth_;
  std::unique_ptr<MissionStore> store_;
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
  bool shut_down_ = false;
};

}  // namespace oaipp::server
