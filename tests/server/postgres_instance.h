// A real PostgreSQL 15 server for a test, in a temporary folder of its own:
// initdb on the first Start, listening on 127.0.0.1 (a free port) and on a
// unix socket in that folder, fsync on. Stop and Start again restart the
// same data folder on the same port, so a store opened before keeps its URI.
// PostgreSQL refuses to run as root, so the server runs as the `postgres`
// system user (tests run as root or as postgres; Available() says whether
// they can). A cluster of the Debian package (port 5432) is never touched.
//
//   if (!oaipp::testing::PostgresInstance::Available()) GTEST_SKIP() << "no PostgreSQL 15";
//   oaipp::testing::PostgresInstance pg;
//   ASSERT_TRUE(pg.Start());
//   auto store = OpenPostgresStore(pg.uri());
//   pg.Stop();   // the store now fails with Unavailable ...
//   pg.Start();  // ... and works again
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <grp.h>
#include <netinet/in.h>
#include <pwd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <vector>

#include "tests/server/free_port.h"

namespace oaipp::testing {

class PostgresInstance {
 public:
  static constexpr const char* kBinDir = "/usr/lib/postgresql/15/bin";

  PostgresInstance() = default;
  ~PostgresInstance() {
    Stop();
    if (!dir_.empty()) {
      std::error_code ignored;
      std::filesystem::remove_all(dir_, ignored);
    }
  }
  PostgresInstance(const PostgresInstance&) = delete;
  PostgresInstance& operator=(const PostgresInstance&) = delete;

  // Whether this process can run one: the binaries are installed, the
  // `postgres` user exists, and we are root (to become it) or it.
  static bool Available() {
    for (const char* tool : {"initdb", "pg_ctl", "postgres"}) {
      // Appended in place: GCC 12 under ThreadSanitizer reports a false
      // -Warray-bounds in the operator+ of a temporary string here.
      std::string path = kBinDir;
      path.append("/").append(tool);
      if (access(path.c_str(), X_OK) != 0) return false;
    }
    const passwd* user = getpwnam("postgres");
    return user != nullptr && (geteuid() == 0 || geteuid() == user->pw_uid);
  }

  // Starts the server and waits (pg_ctl -w, at most 30 s) until it accepts
  // connections. The first call creates the folder and the cluster; later
  // calls restart that cluster. False (with the server's log on stderr)
  // when it did not start.
  bool Start() {
    if (running_) return true;
    if (!initialized_ && !Init()) return false;
    // A port that was free when picked can be taken before the server binds
    // it; only then is another one tried (the first start only: a restart
    // keeps the URI that stores were opened with).
    for (int attempt = 0; attempt < 3; ++attempt) {
      if (Run({Tool("pg_ctl"), "start", "-w", "-t", "30", "-D", Data(), "-l", Log()},
              dir_ + "/pg_ctl.out")) {
        running_ = true;
        started_once_ = true;
        return true;
      }
      if (started_once_ || !PortTaken()) break;
      if (!PickPort() || !Configure()) break;
    }
    PrintTail(dir_ + "/pg_ctl.out");
    PrintTail(Log());
    return false;
  }

  // Stops the server (fast shutdown: sessions are ended, nothing committed is
  // lost) and waits for it, at most 30 s; an immediate shutdown if that fails.
  void Stop() {
    if (!running_) return;
    running_ = false;
    const std::string out = dir_ + "/pg_ctl.out";
    if (Run({Tool("pg_ctl"), "stop", "-w", "-t", "30", "-m", "fast", "-D", Data()}, out)) return;
    if (!Run({Tool("pg_ctl"), "stop", "-w", "-t", "30", "-m", "immediate", "-D", Data()}, out)) {
      PrintTail(out);
    }
  }

  // postgresql://postgres@127.0.0.1:PORT/postgres (trust authentication).
  [[nodiscard]] std::string uri() const {
    return "postgresql://postgres@127.0.0.1:" + std::to_string(port_) + "/postgres";
  }
  // The same for another database of this server.
  [[nodiscard]] std::string uri(const std::string& database) const {
    return "postgresql://postgres@127.0.0.1:" + std::to_string(port_) + "/" + database;
  }
  // Creates an empty database (name: [a-z0-9_]+), so that tests sharing one
  // server do not see each other's tables.
  bool CreateDatabase(const std::string& name) const {
    return Run({Tool("psql"), "-q", "-h", "127.0.0.1", "-p", std::to_string(port_), "-U",
                "postgres", "-d", "postgres", "-c", "CREATE DATABASE " + name},
               Log());
  }
  [[nodiscard]] int port() const { return port_; }
  // The temporary folder: the cluster in data/, the server's log, the socket.
  [[nodiscard]] const std::string& dir() const { return dir_; }

 private:
  static std::string Tool(const char* name) { return std::string(kBinDir) + "/" + name; }
  std::string Data() const { return dir_ + "/data"; }
  std::string Log() const { return dir_ + "/server.log"; }

  // The folder (in /tmp: every user can reach it, and the socket's path stays
  // under the 107 bytes a unix socket allows), owned by postgres, and the
  // cluster in it.
  bool Init() {
    if (!Available()) {
      std::fprintf(stderr, "PostgresInstance: PostgreSQL 15 or the postgres user is missing\n");
      return false;
    }
    const passwd* user = getpwnam("postgres");
    uid_ = user->pw_uid;
    gid_ = user->pw_gid;
    if (dir_.empty()) {
      char pattern[] = "/tmp/oaipp-pg-XXXXXX";
      if (mkdtemp(pattern) == nullptr) {
        std::perror("PostgresInstance: mkdtemp");
        return false;
      }
      dir_ = pattern;
      if (geteuid() == 0 && chown(dir_.c_str(), uid_, gid_) != 0) {
        std::perror("PostgresInstance: chown");
        return false;
      }
    }
    std::error_code ignored;
    std::filesystem::remove_all(Data(), ignored);  // what a failed initdb left
    // --no-sync only skips initdb's own final fsync of the new files; the
    // server itself runs with fsync on.
    if (!Run({Tool("initdb"), "-D", Data(), "-A", "trust", "-U", "postgres", "-E", "UTF8",
              "--locale=C", "--no-sync"},
             dir_ + "/initdb.out")) {
      PrintTail(dir_ + "/initdb.out");
      return false;
    }
    initialized_ = PickPort() && Configure();
    return initialized_;
  }

  // A port free on 127.0.0.1 now, below the ephemeral range so that a
  // restart finds it still free.
  bool PickPort() {
    port_ = server::testing::FreePort();
    return port_ != 0;
  }

  // Settings appended to postgresql.conf (a later line wins, so a new port
  // simply appends again). Loopback and the private socket only, so nothing
  // here collides with another cluster; fsync and synchronous_commit stay on
  // because the store refuses a database that does not keep commits.
  bool Configure() {
    std::ofstream conf(Data() + "/postgresql.conf", std::ios::app);
    conf << "\n# PostgresInstance\n"
         << "port = " << port_ << "\n"
         << "listen_addresses = '127.0.0.1'\n"
         << "unix_socket_directories = '" << dir_ << "'\n"
         << "fsync = on\n"
         << "synchronous_commit = on\n"
         << "shared_buffers = 16MB\n"
         << "max_connections = 40\n"
         << "logging_collector = off\n";
    return static_cast<bool>(conf.flush());
  }

  bool PortTaken() const {
    std::ifstream log(Log());
    std::string line;
    while (std::getline(log, line)) {
      if (line.find("Address already in use") != std::string::npos) return true;
    }
    return false;
  }

  // Runs args[0] as the postgres user (setuid in the child when we are root:
  // no su/runuser, no PAM) with a clean environment, its output appended to
  // `output`; true when it exits with 0.
  bool Run(const std::vector<std::string>& args, const std::string& output) const {
    // Everything the child needs is built here: between fork and exec only
    // async-signal-safe calls are allowed (the test may have threads).
    std::vector<char*> argv;
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    const std::string home = "HOME=" + dir_;
    std::vector<char*> envp = {const_cast<char*>("PATH=/usr/bin:/bin"),
                               const_cast<char*>("LC_ALL=C"), const_cast<char*>(home.c_str()),
                               nullptr};
    const bool become = geteuid() == 0;
    const pid_t pid = fork();
    if (pid < 0) return false;
    if (pid == 0) {
      const int out = open(output.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
      const int in = open("/dev/null", O_RDONLY);
      if (out < 0 || in < 0 || dup2(in, 0) < 0 || dup2(out, 1) < 0 || dup2(out, 2) < 0) _exit(126);
      // The server must not inherit the test's sockets and files.
      close_range(3, ~0U, 0);
      if (chdir(dir_.c_str()) != 0) _exit(126);
      if (become && (setgroups(0, nullptr) != 0 || setgid(gid_) != 0 || setuid(uid_) != 0)) {
        _exit(126);
      }
      execve(argv[0], argv.data(), envp.data());
      _exit(127);
    }
    int status = 0;
    while (waitpid(pid, &status, 0) < 0) {
      if (errno != EINTR) return false;
    }
    return WIFEXITED(status) && WEXITSTATUS(status) == 0;
  }

  static void PrintTail(const std::string& path, std::size_t lines = 30) {
    std::ifstream in(path);
    std::deque<std::string> tail;
    std::string line;
    while (std::getline(in, line)) {
      tail.push_back(line);
      if (tail.size() > lines) tail.pop_front();
    }
    std::fprintf(stderr, "---- %s (last %zu lines)\n", path.c_str(), tail.size());
    for (const std::string& l : tail) std::fprintf(stderr, "%s\n", l.c_str());
  }

  std::string dir_;
  int port_ = 0;
  uid_t uid_ = 0;
  gid_t gid_ = 0;
  bool initialized_ = false;  // the cluster exists and is configured
  bool running_ = false;
  bool started_once_ = false;
};

}  // namespace oaipp::testing

// Server tests live in oaipp::server, where `testing::` names
// oaipp::server::testing (server_process.h, service_fixture.h) before
// oaipp::testing; this makes `testing::PostgresInstance` work there too.
namespace oaipp::server::testing {
using ::oaipp::testing::PostgresInstance;
}  // namespace oaipp::server::testing
