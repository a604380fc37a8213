// The real oaipp-server binary as a child process on loopback, for tests
// that start, kill and restart it.
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "grpcpp/grpcpp.h"
#include "tests/server/free_port.h"

namespace oaipp::server::testing {

// How long Start waits for the port by default.
inline constexpr std::chrono::seconds kDefaultStartWait{20};

// Starts argv[0] with `args` as a child process and waits (up to `wait`)
// until `port` on 127.0.0.1 accepts connections. Returns the pid, or -1 when
// it could not be started or died first.
// `env`: variables to set in the child ("NAME", "VALUE"), or to remove
// from its environment where VALUE is empty. `stdout_path`: a file the
// child's standard output goes to (appended), or "" to keep the parent's.
inline pid_t SpawnAndWaitForPort(const std::vector<std::string>& args, int port,
                                 std::chrono::milliseconds wait = kDefaultStartWait,
                                 const std::vector<std::pair<std::string, std::string>>& env = {},
                                 const std::string& stdout_path = "") {
  const pid_t pid = fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    if (!stdout_path.empty()) {
      const int fd = open(stdout_path.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      if (fd < 0 || dup2(fd, STDOUT_FILENO) < 0) _exit(126);
      close(fd);
    }
    for (const auto& [name, value] : env) {
      if (value.empty()) {
        unsetenv(name.c_str());
      } else {
        setenv(name.c_str(), value.c_str(), 1);
      }
    }
    std::vector<std::string> copy = args;
    std::vector<char*> argv;
    for (std::string& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  const auto deadline = std::chrono::steady_clock::now() + wait;
  while (std::chrono::steady_clock::now() < deadline) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_port = htons(static_cast<uint16_t>(port));
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    const bool up = connect(fd, reinterpret_cast<sockaddr*>(&sa), sizeof(sa)) == 0;
    close(fd);
    if (up) return pid;
    int status = 0;
    if (waitpid(pid, &status, WNOHANG) == pid) return -1;  // it died at start
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
  return -1;
}

// Any program as a child process that listens on a port of 127.0.0.1.
class ChildProcess {
 public:
  ChildProcess(std::vector<std::string> args, int port) : args_(std::move(args)), port_(port) {}
  ~ChildProcess() { Stop(SIGKILL); }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  [[nodiscard]] int port() const { return port_; }
  [[nodiscard]] std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  [[nodiscard]] bool running() const { return pid_ > 0; }

  // False when it could not be started within `wait` (or is running
  // already).
  bool Start(std::chrono::milliseconds wait = kDefaultStartWait) {
    if (pid_ > 0) return false;
    pid_ = SpawnAndWaitForPort(args_, port_, wait, env_, stdout_path_);
    return pid_ > 0;
  }
  // Sets (or, with an empty value, removes) a variable in the environment
  // of the next Start.
  void SetEnv(std::string name, std::string value) {
    env_.emplace_back(std::move(name), std::move(value));
  }
  // Sends the standard output (the server's log) of the next Start to
  // `path`, appended.
  void SetStdout(std::string path) { stdout_path_ = std::move(path); }
  [[nodiscard]] pid_t pid() const { return pid_; }

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
  std::vector<std::string> args_;
  int port_;
  std::vector<std::pair<std::string, std::string>> env_;
  std::string stdout_path_;
  pid_t pid_ = -1;
};

// The real oaipp-server (OAIPP_SERVER_BINARY) on 127.0.0.1:port.
class ServerProcess : public ChildProcess {
 public:
  // flags: extra command-line flags (e.g. "--data_dir=/tmp/x").
  ServerProcess(int port, const std::vector<std::string>& flags)
      : ChildProcess(Args(port, flags), port) {}

 private:
  static std::vector<std::string> Args(int port, const std::vector<std::string>& flags) {
    std::vector<std::string> args = {OAIPP_SERVER_BINARY,
                                     "--listen=127.0.0.1:" + std::to_string(port),
                                     "--metrics_listen=", "--log_level=warn"};
    args.insert(args.end(), flags.begin(), flags.end());
    return args;
  }
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
