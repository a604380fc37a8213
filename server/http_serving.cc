#include "server/http_serving.h"

#include <sys/socket.h>

#include <chrono>

#include "httplib.h"

namespace oaipp::server {

void ExclusivePort(httplib::Server& http) {
  http.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
}

void ListenThread::Start(httplib::Server* http) {
  thread_ = std::thread([this, http] {
    http->listen_after_bind();
    ended_ = true;
  });
}

void ListenThread::Stop(httplib::Server* http) {
  if (!thread_.joinable()) return;
  while (!ended_ && !http->is_running()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  http->stop();
  thread_.join();
}

}  // namespace oaipp::server
