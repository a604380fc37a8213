#include "server/http_serving.h"

#include <sys/socket.h>

#include <algorithm>
#include <chrono>

#include "httplib.h"

namespace oaipp::server {

int BindExclusive(httplib::Server& http, const std::string& host, int port) {
  http.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  if (port == 0) return std::max(0, http.bind_to_any_port(host));
  return http.bind_to_port(host, port) ? port : 0;
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
