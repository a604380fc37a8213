// A whole cluster on loopback for tests and benchmarks: a real PostgreSQL
// (initdb in a temporary folder), N real oaipp-server replicas with
// --cluster sharing it, and a real HAProxy in front, configured from
// deploy/cluster/haproxy.cfg.in as deploy/cluster/up.sh configures it.
// Replicas can be killed, stopped and restarted one by one.
//
//   LocalCluster cluster;
//   ASSERT_TRUE(cluster.Start({.replicas = 3}));
//   client::Client client = client::Client::Connect(cluster.proxy_address());
//   cluster.replica(1).Stop(SIGKILL);
//   ASSERT_TRUE(cluster.replica(1).Start());
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "tests/server/postgres_instance.h"
#include "tests/server/server_process.h"

namespace oaipp::cluster_testing {

using server::testing::ChildProcess;
using server::testing::FreePort;
using server::testing::PostgresInstance;

class LocalCluster {
 public:
  static constexpr const char* kHaproxy = "/usr/sbin/haproxy";

  struct Options {
    int replicas = 3;
    // Passed to every replica after the cluster's own flags.
    std::vector<std::string> replica_flags = {};
  };

  LocalCluster() = default;
  ~LocalCluster() {
    if (proxy_ != nullptr) proxy_->Stop(SIGKILL);
    for (auto& p : more_proxies_) {
      if (p != nullptr) p->Stop(SIGKILL);
    }
    for (auto& r : replicas_) r->Stop(SIGKILL);
    postgres_.reset();
    if (!dir_.empty()) {
      std::error_code ignored;
      std::filesystem::remove_all(dir_, ignored);
    }
  }
  LocalCluster(const LocalCluster&) = delete;
  LocalCluster& operator=(const LocalCluster&) = delete;

  // Whether PostgreSQL 15 and HAProxy are installed and usable here.
  static bool Available() { return PostgresInstance::Available() && access(kHaproxy, X_OK) == 0; }

  // Starts PostgreSQL, the replicas and the proxy; false (with what failed
  // on stderr) when any did not start.
  bool Start(const Options& options) {
    char pattern[] = "/tmp/oaipp-cluster-test-XXXXXX";
    if (mkdtemp(pattern) == nullptr) return false;
    dir_ = pattern;
    postgres_ = std::make_unique<PostgresInstance>();
    if (!postgres_->Start() || !postgres_->CreateDatabase("oaipp")) {
      std::fprintf(stderr, "LocalCluster: PostgreSQL did not start\n");
      return false;
    }
    for (int i = 0; i < options.replicas; ++i) {
      const int port = FreePort();
      std::vector<std::string> args = {
          OAIPP_SERVER_BINARY, "--cluster", "--store=" + postgres_->uri("oaipp"),
          "--replica_id=" + ReplicaName(i), absl::StrCat("--ring_id=", RingId(i)),
          absl::StrCat("--listen=127.0.0.1:", port), "--metrics_listen=", "--log_level=warn",
          "--shutdown_grace_s=5",
          // as the tests' in-process twins, which
          // they match to 1e-12 relative
          "--dense_backend=eigen"};
      args.insert(args.end(), options.replica_flags.begin(), options.replica_flags.end());
      replicas_.push_back(std::make_unique<ChildProcess>(std::move(args), port));
      if (!replicas_.back()->Start()) {
        std::fprintf(stderr, "LocalCluster: replica %d did not start\n", i);
        return false;
      }
    }
    std::vector<int> order(replicas_.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
    proxy_ = StartProxy(order);
    return proxy_ != nullptr;
  }

  // Another proxy in front of the same replicas, their server lines in
  // `order` (replica numbers; the ring identities stay theirs); its
  // address, or "" when it did not start.
  std::string AddProxy(const std::vector<int>& order) {
    more_proxies_.push_back(StartProxy(order));
    return more_proxies_.back() != nullptr ? more_proxies_.back()->address() : std::string();
  }

  [[nodiscard]] std::string proxy_address() const { return proxy_->address(); }
  [[nodiscard]] int replicas() const { return static_cast<int>(replicas_.size()); }
  ChildProcess& replica(int i) { return *replicas_.at(static_cast<std::size_t>(i)); }
  // The name replica i sends back in x-oaipp-replica.
  static std::string ReplicaName(int i) { return absl::StrCat("replica-", i); }
  // Its identity on the proxies' hash ring (HAProxy's server id): fixed per
  // replica, so that every proxy hashes a mission to the same replica
  // whatever the order of its server lines (docs/cluster.md).
  static int RingId(int i) { return i + 1; }
  [[nodiscard]] std::string store_uri() const { return postgres_->uri("oaipp"); }

 private:
  std::string dir_;
  std::unique_ptr<PostgresInstance> postgres_;
  std::vector<std::unique_ptr<ChildProcess>> replicas_;
  std::unique_ptr<ChildProcess> proxy_;
  std::vector<std::unique_ptr<ChildProcess>> more_proxies_;

  // HAProxy from deploy/cluster/haproxy.cfg.in with one server line per
  // replica, in `order`; nullptr (with what failed on stderr) when it did
  // not start.
  std::unique_ptr<ChildProcess> StartProxy(const std::vector<int>& order) {
    std::string servers;
    for (int i : order) {
      absl::StrAppend(&servers, "    server ", ReplicaName(i), " ", replica(i).address(), " id ",
                      RingId(i), "\n");
    }
    const int proxy_port = FreePort();
    std::ifstream in(std::string(OAIPP_SOURCE_DIR) + "/deploy/cluster/haproxy.cfg.in");
    std::stringstream text;
    text << in.rdbuf();
    const std::string config = absl::StrReplaceAll(
        text.str(),
        {{"@LISTEN@", absl::StrCat("127.0.0.1:", proxy_port)}, {"@SERVERS@\n", servers}});
    const std::string config_path = absl::StrCat(dir_, "/haproxy-", proxy_port, ".cfg");
    std::ofstream(config_path) << config;
    auto proxy = std::make_unique<ChildProcess>(
        std::vector<std::string>{kHaproxy, "-db", "-q", "-f", config_path}, proxy_port);
    if (config.find("@") != std::string::npos || !proxy->Start()) {
      std::fprintf(stderr, "LocalCluster: HAProxy did not start (%s)\n", config_path.c_str());
      return nullptr;
    }
    return proxy;
  }
};

}  // namespace oaipp::cluster_testing
