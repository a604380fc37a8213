// What the server's two small HTTP endpoints (the live view and /metrics)
// share on top of cpp-httplib.
//
//   ExclusivePort(*http);            // before binding
//   ListenThread listener;
//   listener.Start(http.get());      // after bind_to_port
//   ...
//   listener.Stop(http.get());
#pragma once

#include <atomic>
#include <thread>

namespace httplib {
class Server;
}

namespace oaipp::server {

// httplib binds with SO_REUSEPORT by default, so a second process could
// bind the same port and take half the connections; SO_REUSEADDR alone
// still lets a restart rebind at once but refuses a port in use.
void ExclusivePort(httplib::Server& http);

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
