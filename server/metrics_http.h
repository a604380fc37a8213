// The Prometheus scrape endpoint: GET /metrics on its own port, the
// registry's families in the text exposition format.
//
//   MetricsHttp http(metrics.registry());
//   OAIPP_RETURN_IF_ERROR(http.Start("0.0.0.0:9464"));
//   ...
//   http.Stop();
//
// Served with cpp-httplib (as the live view is) rather than prometheus-cpp's
// Exposer: the Exposer's CivetWeb runs its workers on 100 KB stacks, and the
// pthreads build of OpenBLAS, loaded with the program as the system LAPACK,
// takes 60 KB of every thread's stack for its thread-local storage; the
// first scrape then overflowed a worker's stack (SIGSEGV).
#pragma once

#include <atomic>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "prometheus/registry.h"
#include "server/http_serving.h"

namespace oaipp::server {

class MetricsHttp {
 public:
  explicit MetricsHttp(std::shared_ptr<prometheus::Registry> registry);
  MetricsHttp(const MetricsHttp&) = delete;
  MetricsHttp& operator=(const MetricsHttp&) = delete;
  ~MetricsHttp();

  // Binds `listen` ("host:port", "[v6]:port" or a bare port, which binds
  // every IPv4 address, 0.0.0.0; port 0 picks a free one) and serves on
  // threads of its own. InvalidArgument for a malformed address,
  // Unavailable when it cannot be bound, FailedPrecondition when started or
  // stopped before; all name --metrics_listen.
  [[nodiscard]] absl::Status Start(const std::string& listen);
  // The bound port, and host:port as bound (after Start).
  [[nodiscard]] int port() const { return port_; }
  [[nodiscard]] const std::string& address() const { return address_; }
  // Stops serving. Idempotent.
  void Stop();

  // The response body of GET /metrics (public for tests).
  [[nodiscard]] std::string Body() const;

 private:
  std::shared_ptr<prometheus::Registry> registry_;
  std::unique_ptr<httplib::Server> http_;
  ListenThread listener_;
  int port_ = 0;
  std::string address_;
  std::atomic<bool> stopping_{false};
};

}  // namespace oaipp::server
