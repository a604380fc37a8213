// The live mission view: a small read-only web page, served on its own
// port, that lists missions and draws one (map mean and standard
// deviation, obstacles, planned and flown paths, detections, people found),
// updating as the mission's events arrive (server-sent events).
//
// Off unless --web_port is given; it binds loopback by default, and a
// non-loopback address needs a token file, since the page shows mission
// data. With tokens, every request names one (query parameter `token`, or
// an "Authorization: Bearer" header) and sees only its tenant's missions.
//
//   WebView view(&registry, &auth);
//   OAIPP_RETURN_IF_ERROR(view.Start("127.0.0.1", 8080));
//   ...
//   view.Stop();
//
// HTTP routes (docs/ground-stations.md): / (the page), /api/missions,
// /api/missions/{id}, /api/missions/{id}/events.
#pragma once

#include <atomic>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "server/auth.h"
#include "server/http_serving.h"
#include "server/registry.h"

namespace oaipp::server {

class WebView {
 public:
  // Open event streams at once; more are answered 503.
  static constexpr int kMaxStreams = 8;

  // Pointers must outlive the view.
  WebView(MissionRegistry* registry, const Authenticator* auth);
  WebView(const WebView&) = delete;
  WebView& operator=(const WebView&) = delete;
  ~WebView();

  // Binds `address`:`port` (0: any free port) and serves on a thread of its
  // own. Unavailable when the port cannot be bound; InvalidArgument for a
  // non-loopback address without tokens.
  [[nodiscard]] absl::Status Start(const std::string& address, int port);
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

  MissionRegistry* const registry_;
  const Authenticator* const auth_;
  std::unique_ptr<httplib::Server> http_;
  ListenThread listener_;
  int port_ = 0;
  std::atomic<bool> stopping_{false};
  std::atomic<int> streams_{0};
};

}  // namespace oaipp::server
