// What the server's two small HTTP endpoints (the live view and /metrics)
// share on top of cpp-httplib.
//
//   const int port = BindExclusive(*http, "127.0.0.1", 0);   // 0: not bound
//   ListenThread listener;
//   listener.Start(http.get());
//   ...
//   listener.Stop(http.get());
#pragma once

#include <atomic>
#include <string>
#include <thread>

namespace httplib {
class Server;
}

namespace oaipp::server {

// Binds `host`:`port` (0: any free port); the bound port, or 0 when it
// cannot be bound. httplib binds with SO_REUSEPORT by default, so a second
// process could bind the same port and take half the connections; this
// sets SO_REUSEADDR alone, which still lets a restart rebind at once but
// refuses a port in use.
[[nodiscard]] int BindExclusive(httplib::Server& http, const std::string& host, int port);

// The thread that runs listen_after_bind(). httplib's stop() does nothing
// until the listen loop has started, so Stop() waits for that first (or for
// the loop to have ended on its own) before stopping and joining.
class ListenThread {
 public:
  ListenThread() = default;
  ListenThread(const ListenThread&) = delete;
  ListenThread& operator=(const ListenThread&) = delete;
  ~ListenThread() = default;  // Stop() must have been called when started

  void Start(httplib::Server* http);
  // Idempotent; a no-op when never started.
  void Stop(httplib::Server* http);

 private:
  std::thread thread_;
  std::atomic<bool> ended_{false};
};

}  // namespace oaipp::server
