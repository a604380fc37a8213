// The cluster on loopback (tests/cluster/local_cluster.h: a real
// PostgreSQL, replicas of the real binary with --cluster, a real HAProxy)
// measured three ways:
//   load       N E1 missions flown at once through the proxy, with 1 and
//              with 3 replicas: wall time and per-method latencies;
//   proxy      GetMission straight to a replica against the same call
//              through the proxy, alternated: what the proxy adds per call;
//   takeover   a replica killed with SIGKILL while it holds missions: for
//              each of its missions, the time from the kill to the first
//              answered call through the proxy (the proxy noticing, another
//              replica claiming the mission and rebuilding it from its
//              snapshot and log tail), over several rounds.
//
//   build/tests/bench/server/cluster_bench --missions=30 --rounds=3
#include <signal.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <random>
#include <thread>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/str_cat.h"
#include "tests/bench/server/latencies.h"
#include "tests/cluster/e1_flight.h"
#include "tests/cluster/local_cluster.h"

ABSL_FLAG(int, missions, 30, "missions flown at once in the load runs (and held in takeover)");
ABSL_FLAG(double, budget_s, 150.0, "flight budget per mission in the load runs, seconds");
ABSL_FLAG(std::vector<std::string>, replicas, std::vector<std::string>({"1", "3"}),
          "replica counts for the load runs");
ABSL_FLAG(int, proxy_calls, 2000, "GetMission calls each way in the proxy run");
ABSL_FLAG(absl::Duration, settle, absl::Seconds(5),
          "takeover: the wait after a killed replica is restarted, before the next round");
ABSL_FLAG(int, rounds, 3, "kills in the takeover run (a different replica each time)");
ABSL_FLAG(std::vector<std::string>, runs, std::vector<std::string>({"load", "proxy", "takeover"}),
          "what to measure");

namespace oaipp::cluster_testing {
namespace {

using Clock = std::chrono::steady_clock;

double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

// Retries every 20-100 ms, so that the time to answer again is measured
// finely.
client::ClientOptions Patient() {
  return PatientClient(100, absl::Milliseconds(20), absl::Milliseconds(100));
}

// more_flags: after the others, so they win.
bool StartCluster(LocalCluster& cluster, int replicas,
                  const std::vector<std::string>& more_flags = {}) {
  std::vector<std::string> flags = {"--planning_queue=256", "--max_missions=256",
                                    "--worker_threads=64"};
  flags.insert(flags.end(), more_flags.begin(), more_flags.end());
  return cluster.Start({.replicas = replicas, .replica_flags = flags});
}

void Load(int replicas) {
  LocalCluster cluster;
  if (!StartCluster(cluster, replicas)) std::exit(1);
  const int missions = absl::GetFlag(FLAGS_missions);
  bench::Latencies latencies;
  std::atomic<int> finished{0};
  const auto start = Clock::now();
  std::vector<std::thread> threads;
  for (int m = 0; m < missions; ++m) {
    threads.emplace_back([&, m] {
      client::Client client = client::Client::Connect(cluster.proxy_address(), Patient());
      E1Flight flight;
      flight.on_call = [&](const char* method, double ms, bool ok) {
        latencies.Add(method, ms, ok);
      };
      const absl::Status flown =
          FlyE1(client, absl::StrCat("load-", m), static_cast<std::uint32_t>(m + 1),
                absl::GetFlag(FLAGS_budget_s), flight);
      if (flown.ok()) {
        ++finished;
      } else {
        std::fprintf(stderr, "mission %d: %s\n", m, flown.ToString().c_str());
      }
    });
  }
  for (std::thread& t : threads) t.join();
  const double wall = std::chrono::duration<double>(Clock::now() - start).count();
  std::printf("load: %d replica(s), %d E1 missions through the proxy, %d finished, wall %.1f s\n",
              replicas, missions, finished.load(), wall);
  latencies.Print(wall);
  std::fflush(stdout);
}

void Proxy() {
  LocalCluster cluster;
  if (!StartCluster(cluster, 1)) std::exit(1);
  client::Client via_proxy = client::Client::Connect(cluster.proxy_address(), Patient());
  client::Client direct = client::Client::Connect(cluster.replica(0).address(), Patient());
  if (!via_proxy.CreateMission(E1FlightSpec(1, 150), "proxy-1").ok()) std::exit(1);
  std::vector<double> through, straight;
  const int calls = absl::GetFlag(FLAGS_proxy_calls);
  for (int i = 0; i < calls + 50; ++i) {  // the first 50 pairs warm up
    const auto t0 = Clock::now();
    const bool a = via_proxy.GetMission("missions/proxy-1").ok();
    const auto t1 = Clock::now();
    const bool b = direct.GetMission("missions/proxy-1").ok();
    const auto t2 = Clock::now();
    if (!a || !b) std::exit(1);
    if (i < 50) continue;
    through.push_back(Ms(t1 - t0));
    straight.push_back(Ms(t2 - t1));
  }
  std::vector<double> added(through.size());
  for (std::size_t i = 0; i < added.size(); ++i) added[i] = through[i] - straight[i];
  std::printf("proxy: GetMission, %d calls each way, alternated, one replica\n", calls);
  std::printf("  %-14s %9s %9s\n", "", "p50 ms", "p99 ms");
  std::printf("  %-14s %9.3f %9.3f\n", "direct", Quantile(straight, 0.5), Quantile(straight, 0.99));
  std::printf("  %-14s %9.3f %9.3f\n", "via proxy", Quantile(through, 0.5),
              Quantile(through, 0.99));
  std::printf("  %-14s %9.3f %9.3f   (pair by pair)\n", "added", Quantile(added, 0.5),
              Quantile(added, 0.99));
  std::fflush(stdout);
}

void Takeover() {
  LocalCluster cluster;
  // The server's own dense backend for the rebuilds' replays (LocalCluster
  // gives the tests Eigen, to match their in-process twins bit for bit).
  if (!StartCluster(cluster, 3, {"--dense_backend=openblas"})) std::exit(1);
  const int missions = absl::GetFlag(FLAGS_missions);
  // Each mission with a snapshot and a tail behind it: 20 measurements
  // (snapshots every 16).
  std::vector<std::unique_ptr<client::Client>> clients;
  for (int m = 0; m < missions; ++m) {
    clients.push_back(std::make_unique<client::Client>(
        grpc::CreateChannel(cluster.proxy_address(), grpc::InsecureChannelCredentials()),
        Patient()));
    const std::string id = absl::StrCat("held-", m);
    if (!clients[m]->CreateMission(E1FlightSpec(static_cast<std::uint32_t>(m + 1), 150), id).ok()) {
      std::exit(1);
    }
    for (int k = 0; k < 20; ++k) {
      v1::Vector3 p;
      p.set_x(-12 + k);
      p.set_y(-12 + (m % 24));
      p.set_z(10);
      if (!clients[m]->AddMeasurement(bench::E1Measurement("missions/" + id, p, 7.0 * k)).ok()) {
        std::exit(1);
      }
    }
  }
  std::vector<double> takeover_ms;
  std::mt19937 rng(20261123);
  for (int round = 0; round < absl::GetFlag(FLAGS_rounds); ++round) {
    // Where each mission is now.
    std::vector<std::string> holder(missions);
    for (int m = 0; m < missions; ++m) {
      if (!clients[m]->GetMission(absl::StrCat("missions/held-", m)).ok()) std::exit(1);
      holder[m] = clients[m]->last_replica();
    }
    const int victim = round % cluster.replicas();
    std::this_thread::sleep_for(std::chrono::milliseconds(
        std::uniform_int_distribution<int>(0, 500)(rng)));  // off the health checks' beat
    const auto killed = Clock::now();
    cluster.replica(victim).Stop(SIGKILL);
    std::vector<std::thread> threads;
    std::mutex mu;
    int moved = 0;
    for (int m = 0; m < missions; ++m) {
      if (holder[m] != LocalCluster::ReplicaName(victim)) continue;
      ++moved;
      threads.emplace_back([&, m] {
        if (!clients[m]->GetMission(absl::StrCat("missions/held-", m)).ok()) std::exit(1);
        const double ms = Ms(Clock::now() - killed);
        std::lock_guard<std::mutex> lock(mu);
        takeover_ms.push_back(ms);
      });
    }
    for (std::thread& t : threads) t.join();
    std::printf(
        "takeover round %d: replica-%d killed, %d of its missions answered again after "
        "%.0f ms (median)\n",
        round + 1, victim, moved,
        Quantile(std::vector<double>(takeover_ms.end() - moved, takeover_ms.end()), 0.5));
    if (!cluster.replica(victim).Start()) std::exit(1);
    // The proxy sees it up again, and it reads the missions it stands by
    // for (about 80 ms of CPU each): the next kill finds a settled cluster.
    std::this_thread::sleep_for(absl::ToChronoMilliseconds(absl::GetFlag(FLAGS_settle)));
  }
  std::printf(
      "takeover: %zu missions over %d kills: p50 %.0f ms, p99 %.0f ms, max %.0f ms "
      "(from SIGKILL to the first answered call)\n",
      takeover_ms.size(), absl::GetFlag(FLAGS_rounds), Quantile(takeover_ms, 0.5),
      Quantile(takeover_ms, 0.99), Quantile(takeover_ms, 1.0));
  std::fflush(stdout);
}

}  // namespace
}  // namespace oaipp::cluster_testing

int main(int argc, char** argv) {
  absl::ParseCommandLine(argc, argv);
  if (!oaipp::cluster_testing::LocalCluster::Available()) {
    std::fprintf(stderr, "needs PostgreSQL 15 and HAProxy (deploy/install-deps.sh)\n");
    return 1;
  }
  for (const std::string& run : absl::GetFlag(FLAGS_runs)) {
    if (run == "load") {
      for (const std::string& n : absl::GetFlag(FLAGS_replicas)) {
        oaipp::cluster_testing::Load(std::stoi(n));
      }
    } else if (run == "proxy") {
      oaipp::cluster_testing::Proxy();
    } else if (run == "takeover") {
      oaipp::cluster_testing::Takeover();
    } else {
      std::fprintf(stderr, "--runs: unknown run '%s' (load, proxy, takeover)\n", run.c_str());
      return 2;
    }
  }
  return 0;
}
