// The live mission view: a small read-only web page, served on its own
// port, that lists missions and draws one (map mean and standard
// deviation, obstacles, planned and flown paths, detections, people found),
// updating as the mission's events arrive (server-sent events).
//
// Off unless --web_port is given; it binds loopback by default. Off
// loopback it needs tokens (--token_file) and TLS (the server's --tls_cert
// and --tls_key, then it serves HTTPS), since the page shows mission data.
// With tokens, a request carries an "Authorization: Bearer" header, or the
// HttpOnly session cookie that POST /api/session hands out for one (what
// the page uses, so that its event stream needs no token in its URL); a
// token in a URL is refused. Each sees only its tenant's missions.
// Requests whose Host is not one of the view's own names (its address, the
// loopback names on loopback, and --web_hosts), or whose Origin is not
// on one, are refused: a page elsewhere cannot read the view by DNS
// rebinding or script it from another site.
//
//   WebView view(&registry, &auth);
//   OAIPP_RETURN_IF_ERROR(view.Start({.address = "127.0.0.1", .port = 8080}));
//   ...
//   view.Stop();
//
// HTTP routes (docs/ground-stations.md): / (the page), POST and DELETE
// /api/session, /api/missions, /api/missions/{id},
// /api/missions/{id}/events.
#pragma once

#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/container/flat_hash_map.h"
#include "absl/container/flat_hash_set.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "server/auth.h"
#include "server/http_serving.h"
#include "server/registry.h"

namespace oaipp::server {

struct WebViewOptions {
  std::string address = "127.0.0.1";
  int port = 0;  // 0: any free port
  // PEM files: with both, the view serves HTTPS (required off loopback).
  std::string tls_cert = {};
  std::string tls_key = {};
  // Names the view is reached by besides its address ("host" or
  // "host:port"), e.g. the machine's DNS name.
  std::vector<std::string> host_names = {};
};

class WebView {
 public:
  // Open event streams at once; more are answered 503.
  static constexpr int kMaxStreams = 8;

  // Pointers must outlive the view.
  WebView(MissionRegistry* registry, const Authenticator* auth);
  WebView(const WebView&) = delete;
  WebView& operator=(const WebView&) = delete;
  ~WebView();

  // Sessions held at once (the oldest is dropped past it) and how long one
  // lasts.
  static constexpr int kMaxSessions = 1024;
  static constexpr absl::Duration kSessionLifetime = absl::Hours(12);

  // Binds options.address:options.port and serves on a thread of its own.
  // Unavailable when the port cannot be bound or the TLS files cannot be
  // read; InvalidArgument naming the flag for a non-loopback address
  // without tokens or without TLS, and for a wildcard address without
  // host_names.
  [[nodiscard]] absl::Status Start(const WebViewOptions& options);
  // The bound port (after Start).
  [[nodiscard]] int port() const { return port_; }
  // Ends every event stream and stops serving. Idempotent.
  void Stop();

  // The JSON the page reads (public for tests): the tenant's missions, and
  // one mission's picture data. NotFound as MissionRegistry::Get.
  [[nodiscard]] std::string MissionsJson(const std::string& tenant) const;
  [[nodiscard]] absl::StatusOr<std::string> MissionJson(const std::string& id,
                                                        const std::string& tenant) const;

 private:
  void Routes();
  // Whether a Host header / an Origin header names this view.
  [[nodiscard]] bool HostAllowed(const std::string& host) const;
  [[nodiscard]] bool OriginAllowed(const std::string& origin) const;
  // A new session for `tenant` (its cookie value), and the tenant of one.
  std::string NewSession(const std::string& tenant);
  [[nodiscard]] std::optional<std::string> SessionTenant(const std::string& id);

  MissionRegistry* const registry_;
  const Authenticator* const auth_;
  std::unique_ptr<httplib::Server> http_;
  bool tls_ = false;
  absl::flat_hash_set<std::string> hosts_;  // lower case, with and without the port
  struct Session {
    std::string tenant;
    absl::Time expires;
  };
  absl::Mutex sessions_mu_;
  absl::flat_hash_map<std::string, Session> sessions_ ABSL_GUARDED_BY(sessions_mu_);
  ListenThread listener_;
  int port_ = 0;
  std::atomic<bool> stopping_{false};
  std::atomic<int> streams_{0};
};

}  // namespace oaipp::server
