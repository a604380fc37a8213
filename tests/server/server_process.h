// The real oaipp-server binary as a child process on loopback, for tests
// that start, kill and restart it.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include "grpcpp/grpcpp.h"

namespace oaipp::server::testing {

class ServerProcess {
 public:
  // flags: extra command-line flags (e.g. "--data_dir=/tmp/x").
  ServerProcess(int port, std::vector<std::string> flags) : port_(port), flags_(std::move(flags)) {}
  ~ServerProcess() { Stop(SIGKILL); }
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  [[nodiscard]] std::string address() const { return "127.0.0.1:" + std::to_string(port_); }

  // Starts the binary and waits (up to ~20 s) until the port accepts
  // connections. False when it could not be started.
  bool Start() {
    pid_ = fork();
    if (pid_ < 0) return false;
    if (pid_ == 0) {
      std::vector<std::string> args = {OAIPP_SERVER_BINARY, "--listen=" + address(),
                                       "--metrics_listen=", "--log_level=warn"};
      args.insert(args.end(), flags_.begin(), flags_.end());
      std::vector<char*> argv;
      for (std::string& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      execv(OAIPP_SERVER_BINARY, argv.data());
      _exit(127);
    }
    for (int attempt = 0; attempt < 400; ++attempt) {
      const int fd = socket(AF_INET, SOCK_STREAM, 0);
      sockaddr_in sa{};
      sa.sin_family = AF_INET;
      sa.sin_port = htons(static_cast<uint16_t>(port_));
      sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
      const bool up = connect(fd, reinterpret_cast<sockaddr*>(&sa), sizeof(sa)) == 0;
      close(fd);
      if (up) return true;
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {  // it died at start
        pid_ = -1;
        return false;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  }

  // Sends `signal` and waits for the process; returns its wait status (-1
  // when none was running).
  int Stop(int signal) {
    if (pid_ <= 0) return -1;
    kill(pid_, signal);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
    return status;
  }

 private:
  int port_;
  std::vector<std::string> flags_;
  pid_t pid_ = -1;
};

// A channel that reconnects quickly after the server comes back.
inline std::shared_ptr<grpc::Channel> QuickReconnectChannel(const std::string& address) {
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 50);
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, 50);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 200);
  return grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args);
}

}  // namespace oaipp::server::testing
