// Many missions at once on one server: each flies the E1 mission for its
// budget (plan, fly the path, measure at the sensor's shots, replan), all
// concurrently over loopback TCP.
//
// --pace=real_time (the default) flies each path in wall-clock time, as a
// UAV would: a shot's measurement is sent when the UAV reaches it, and the
// next plan is asked for when the path ends. A mission then lasts its
// budget plus the time it waited for plans, so the wall time says whether
// the server keeps that many UAVs flying in real time. --pace=as_fast asks
// for the next plan as soon as the last one is answered: a throughput test.
//
// Prints throughput, per-method latency percentiles, the plans' search
// share (overload shedding), memory per mission, peak RSS and the mean E1
// RSE; --json writes the same figures and every call (for
// tests/bench/server/plot_load.py). --compare_alone flies the same missions
// again one at a time (as fast as the server answers) and compares their
// RSE. With several --stores the load runs once on each.
//
//   build/tests/bench/server/server_load --missions=100 --budget_s=150 --json=load.json
//   /usr/bin/python3 tests/bench/server/plot_load.py load.json load.png
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/reflection.h"
#include "absl/flags/usage.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "api/metadata.h"
#include "api/plan.h"
#include "core/planning/information.h"
#include "grpcpp/grpcpp.h"
#include "nlohmann/json.hpp"
#include "server/flags/flags.h"
#include "server/library_settings.h"
#include "server/server.h"
#include "server/service.h"
#include "server/store/open_store.h"
#include "spdlog/spdlog.h"
#include "tests/bench/server/e1_mission.h"
#include "tests/bench/server/latencies.h"
#include "tests/server/postgres_instance.h"

ABSL_FLAG(int, missions, 50, "missions flown at once");
ABSL_FLAG(double, budget_s, 150.0, "flight budget per mission, seconds");
ABSL_FLAG(std::string, pace, "real_time",
          "real_time: each path is flown in wall-clock time; as_fast: the next plan is asked for "
          "as soon as the last one is answered");
ABSL_FLAG(int, generations, 45, "CMA-ES generations per plan");
ABSL_FLAG(int, stall_generations, 0,
          "spec.planner.stall_generations: a plan's search stops once its best score beats the "
          "best of this many generations before by no more than --stall_tolerance times it "
          "(0: never)");
ABSL_FLAG(double, stall_tolerance, 1e-3, "spec.planner.stall_tolerance");
ABSL_FLAG(double, first_plan_budget_s, 0.0,
          "each mission asks for its first path with this planning_budget_s, in every run "
          "(0: none): what the first plans' search is worth to the RSE");
ABSL_FLAG(double, replan_cut_within_s, 0.0,
          "an experiment (it costs RSE, docs/capacity.md): a plan whose search was cut "
          "(stats.search_fraction < 1, or stop_reason deadline) is flown only to its first "
          "shot after a point of its own in [0, this) s, and the next plan is asked for from "
          "the moving state there, whose path takes that shot first; the points are spread "
          "over the missions so that those replans do not arrive together (0: every path is "
          "flown to its end)");
ABSL_FLAG(double, launch_spread_s, 0.0,
          "missions start one after another, evenly over this many seconds (0: all at once, "
          "the default); not in the one-at-a-time run");
ABSL_FLAG(std::vector<std::string>, stores, {"memory"},
          "stores to run the load on, in turn: memory, sqlite (in a fresh folder under "
          "--data_dir), postgresql (a PostgreSQL server started for the run, as the tests "
          "start one) or a postgresql:// URI");
ABSL_FLAG(bool, compare_alone, false,
          "afterwards fly the same missions one at a time (as fast as the server answers, "
          "nothing shed) and compare the mean RSE");
ABSL_FLAG(std::string, json, "", "write the figures and every call to this file");

namespace {

using Clock = std::chrono::steady_clock;
using oaipp::bench::Latencies;
namespace v1 = oaipp::v1;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

struct MissionResult {
  bool finished = false;
  double rse = 0.0;
  int found = 0;
  int plans = 0;
  int cut_replans = 0;           // cut plans left early (--replan_cut_within_s)
  int take_off_refusals = 0;     // first plans refused by take-off pacing
  double take_off_wait_s = 0.0;  // from creation to the first path's answer
  double wall_s = 0.0;
  // In the air between paths, waiting for the next (real time): each path
  // ends where its last shot is taken, so a replan cannot be asked sooner.
  double hover_s = 0.0;
  // Each plan: when it was asked for (s since the load started), the
  // planner's wall time (s), evaluations, generations, search share, the
  // wait for a planner (s), and 1 when the deadline ended its search.
  std::vector<std::array<double, 7>> plan_stats;
};

// What one run of the load measured.
struct LoadResult {
  std::string label;
  double wall_s = 0.0;
  Latencies latencies;
  std::vector<MissionResult> missions;
  double bytes_per_mission = 0.0;  // as the server reports it (map_bytes)
  long peak_rss_kb = 0;
  std::string dense_backend;  // the server's (--dense_backend, as loaded)
};

double Mean(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  return v.empty() ? 0.0 : sum / static_cast<double>(v.size());
}

// Standard error of the mean.
double StdErr(const std::vector<double>& v) {
  if (v.size() < 2) return 0.0;
  const double m = Mean(v);
  double ss = 0.0;
  for (double x : v) ss += (x - m) * (x - m);
  return std::sqrt(ss / static_cast<double>(v.size() - 1) / static_cast<double>(v.size()));
}

std::vector<double> Rses(const LoadResult& r) {
  std::vector<double> out;
  for (const MissionResult& m : r.missions) {
    if (m.finished) out.push_back(m.rse);
  }
  return out;
}

// Each plan's search share (stats.search_fraction), over finished missions.
std::vector<double> SearchShares(const LoadResult& r) {
  std::vector<double> out;
  for (const MissionResult& m : r.missions) {
    if (!m.finished) continue;
    for (const auto& plan : m.plan_stats) out.push_back(plan[4]);
  }
  return out;
}

long PeakRssKb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss;
}

// Flies mission `m` against `stub`: returns what it ended with. `paced`
// flies each path in wall-clock time.
MissionResult FlyMission(v1::MissionService::Stub& stub, int m, bool paced, Clock::time_point t0,
                         LoadResult& out, std::mutex& out_mu) {
  const double budget = absl::GetFlag(FLAGS_budget_s);
  Latencies& latencies = out.latencies;
  auto timed = [&](const char* method, auto call) {
    const auto start = Clock::now();
    const grpc::Status status = call();
    latencies.Add(method, std::chrono::duration<double, std::milli>(Clock::now() - start).count(),
                  status.ok(), Seconds(start - t0));
    return status;
  };
  MissionResult result;
  const auto mission_start = Clock::now();
  const std::string id = absl::StrCat("load-", m);
  const std::string name = "missions/" + id;
  v1::Mission created;
  const grpc::Status made = timed("CreateMission", [&] {
    grpc::ClientContext c;
    v1::CreateMissionRequest r;
    r.set_mission_id(id);
    *r.mutable_spec() = oaipp::bench::E1Spec(absl::GetFlag(FLAGS_generations));
    r.mutable_spec()->mutable_planner()->set_seed(static_cast<std::uint32_t>(m + 1));
    r.mutable_spec()->mutable_planner()->set_stall_generations(
        absl::GetFlag(FLAGS_stall_generations));
    r.mutable_spec()->mutable_planner()->set_stall_tolerance(absl::GetFlag(FLAGS_stall_tolerance));
    r.mutable_spec()->set_budget_s(budget);
    return stub.CreateMission(&c, r, &created);
  });
  if (!made.ok()) return result;
  v1::UavState state = created.spec().start();
  int shots = 0;
  const double first_budget = absl::GetFlag(FLAGS_first_plan_budget_s);
  while (state.mission_time_s() < budget) {
    v1::PlanPathResponse path;
    const auto asked = Clock::now();
    double asked_s = Seconds(asked - t0);
    std::optional<std::int64_t> retry_after_ms;
    auto plan = [&] {
      grpc::ClientContext c;
      c.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
      v1::PlanPathRequest r;
      r.set_name(name);
      *r.mutable_state() = state;
      r.set_request_id(absl::StrCat("plan-", result.plans));
      if (first_budget > 0.0 && result.plans == 0) r.set_planning_budget_s(first_budget);
      const grpc::Status status = stub.PlanPath(&c, r, &path);
      retry_after_ms = oaipp::api::RetryAfterMs(c);
      return status;
    };
    grpc::Status planned;
    while (true) {
      const auto start = Clock::now();
      planned = plan();
      const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
      // Take-off pacing: wait on the ground as long as the server says.
      if (planned.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED && result.plans == 0 &&
          retry_after_ms.has_value() && *retry_after_ms <= 60'000) {
        latencies.Add("PlanPath (take-off refused)", ms, true, Seconds(start - t0));
        ++result.take_off_refusals;
        std::this_thread::sleep_for(std::chrono::milliseconds(*retry_after_ms));
        asked_s = Seconds(Clock::now() - t0);
        continue;
      }
      latencies.Add("PlanPath", ms, planned.ok(), Seconds(start - t0));
      break;
    }
    if (!planned.ok()) return result;
    if (result.plans == 0) result.take_off_wait_s = Seconds(Clock::now() - mission_start);
    if (result.plans > 0 && paced) result.hover_s += Seconds(Clock::now() - asked);
    ++result.plans;
    result.plan_stats.push_back(
        {asked_s, path.stats().wall_time_s(), static_cast<double>(path.stats().evaluations()),
         static_cast<double>(path.stats().generations()), path.stats().search_fraction(),
         path.stats().queued_s(), path.stats().stop_reason() == "deadline" ? 1.0 : 0.0});
    const auto flight_start = Clock::now();
    double fly = std::min(path.trajectory().duration_s(), budget - state.mission_time_s());
    // --replan_cut_within_s: a plan cut by load (shed, or ended by the
    // latency bound rather than a budget this mission asked for) is left
    // at its first shot after a point of this mission's own (golden-ratio
    // spread, no two missions alike), so the fleet's replans spread out.
    const double whole = fly;
    const bool cut =
        path.stats().search_fraction() < 1.0 ||
        (path.stats().stop_reason() == "deadline" && !(result.plans == 1 && first_budget > 0.0));
    if (const double within = absl::GetFlag(FLAGS_replan_cut_within_s); within > 0.0 && cut) {
      const double from = std::max(1e-3, within * std::fmod(0.6180339887498949 * (m + 1), 1.0));
      for (const auto& pose : path.measurement_poses()) {
        if (pose.t_s() >= from && pose.t_s() < whole) {
          fly = pose.t_s();
          break;
        }
      }
    }
    for (const auto& pose : path.measurement_poses()) {
      // Left early, the shot where it is left is the next path's first.
      if (fly < whole ? pose.t_s() >= fly : pose.t_s() > fly) break;
      if (paced)
        std::this_thread::sleep_until(flight_start + std::chrono::duration<double>(pose.t_s()));
      timed("AddMeasurement", [&] {
        grpc::ClientContext c;
        v1::AddMeasurementRequest r =
            oaipp::bench::E1Measurement(name, pose.position_m(), pose.mission_time_s());
        r.set_request_id(absl::StrCat("shot-", shots++));
        v1::AddMeasurementResponse reply;
        return stub.AddMeasurement(&c, r, &reply);
      });
    }
    if (paced) std::this_thread::sleep_until(flight_start + std::chrono::duration<double>(fly));
    if (fly < whole) {
      absl::StatusOr<oaipp::PolynomialTrajectory> flown =
          oaipp::api::TrajectoryFromProto(path.trajectory());
      if (!flown.ok()) return result;
      ++result.cut_replans;
      state = oaipp::api::StateAlongPath(*flown, fly, state.mission_time_s());
      continue;
    }
    const auto& last = path.trajectory().samples(path.trajectory().samples_size() - 1);
    *state.mutable_position_m() = last.position_m();
    state.clear_velocity_m_s();  // paths end at rest
    state.clear_acceleration_m_s2();
    state.set_mission_time_s(state.mission_time_s() + path.trajectory().duration_s());
  }
  v1::GetMapResponse map;
  const grpc::Status got = timed("GetMap", [&] {
    grpc::ClientContext c;
    v1::GetMapRequest r;
    r.set_name(name);
    r.set_include_cells(true);
    return stub.GetMap(&c, r, &map);
  });
  if (!got.ok()) return result;
  const std::vector<double> mean(map.mean().begin(), map.mean().end());
  result.rse = oaipp::bench::E1().simulation.Rse(mean);
  result.found = oaipp::bench::E1().simulation.TargetsFound(mean);
  result.wall_s = Seconds(Clock::now() - mission_start);
  result.finished = true;
  {
    std::lock_guard<std::mutex> lock(out_mu);
    out.bytes_per_mission += static_cast<double>(created.map_bytes());
  }
  return result;
}

// Flies the load against a fresh server built from `options` (its store
// among them): all missions at once, or (alone) one after another with
// nothing shed.
void RunLoad(oaipp::server::ServerOptions options, bool alone, LoadResult& out) {
  using namespace oaipp;
  const int missions = absl::GetFlag(FLAGS_missions);
  const bool paced = !alone && absl::GetFlag(FLAGS_pace) == "real_time";
  options.listen = "127.0.0.1:0";
  options.max_missions = std::max(options.max_missions, missions + 1);
  if (alone) {
    options.shed_above = 0.0;
    options.shed_after_wait_s = 0.0;
    options.plan_latency_s = 0.0;
    options.max_take_off_plans = 0;
  }
  absl::StatusOr<std::unique_ptr<server::Server>> started = server::Server::Start(options);
  if (!started.ok()) {
    std::fprintf(stderr, "%s\n", started.status().ToString().c_str());
    std::exit(1);
  }
  server::Server& server = **started;
  out.dense_backend = server.dense_backend().name();
  std::printf("Kalman update on %s; objective's solves in %s precision\n",
              out.dense_backend.c_str(), options.objective_precision.c_str());
  const int port = server.port();
  auto channel =
      grpc::CreateChannel(absl::StrCat("127.0.0.1:", port), grpc::InsecureChannelCredentials());
  auto stub = v1::MissionService::NewStub(channel);

  out.missions.assign(missions, {});
  std::mutex out_mu;
  std::atomic<int> done{0};
  const auto start = Clock::now();
  // Progress on stderr every 10 s.
  std::atomic<bool> running{true};
  std::thread progress([&] {
    auto next = start + std::chrono::seconds(10);
    while (running.load()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      if (Clock::now() >= next) {
        std::fprintf(stderr, "  %.0f s: %d of %d missions done, %zu plans\n",
                     Seconds(Clock::now() - start), done.load(), missions,
                     out.latencies.Count("PlanPath"));
        next += std::chrono::seconds(10);
      }
    }
  });
  if (alone) {
    for (int m = 0; m < missions; ++m) {
      out.missions[m] = FlyMission(*stub, m, false, start, out, out_mu);
      ++done;
    }
  } else {
    std::vector<std::thread> threads;
    for (int m = 0; m < missions; ++m) {
      threads.emplace_back([&, m] {
        // Launches spread evenly over --launch_spread_s (0: all at once).
        std::this_thread::sleep_until(
            start +
            std::chrono::duration<double>(absl::GetFlag(FLAGS_launch_spread_s) * m / missions));
        out.missions[m] = FlyMission(*stub, m, paced, start, out, out_mu);
        ++done;
      });
    }
    for (auto& t : threads) t.join();
  }
  out.wall_s = Seconds(Clock::now() - start);
  running = false;
  progress.join();
  out.bytes_per_mission /= std::max(1, done.load());
  out.peak_rss_kb = PeakRssKb();
  server.Shutdown(absl::ZeroDuration());
}

void Print(LoadResult& r, int missions, double budget, const std::string& pace,
           int planning_threads) {
  int finished = 0;
  for (const MissionResult& m : r.missions) finished += m.finished ? 1 : 0;
  std::printf(
      "%d missions of %.0f s flight each (%s), %d finished, wall %.1f s, %d planning "
      "threads\n",
      missions, budget, pace.c_str(), finished, r.wall_s, planning_threads);
  r.latencies.Print(r.wall_s);
  int shed = 0;
  const std::vector<double> shares = SearchShares(r);
  for (double f : shares) shed += f < 1.0 ? 1 : 0;
  std::printf("plans shed: %d of %zu (mean search share %.3f)\n", shed, shares.size(),
              Mean(shares));
  std::vector<double> queued;
  int cut = 0;
  for (const MissionResult& m : r.missions) {
    if (!m.finished) continue;
    for (const auto& plan : m.plan_stats) {
      queued.push_back(plan[5]);
      cut += plan[6] > 0.0 ? 1 : 0;
    }
  }
  std::printf("waits for a planner: mean %.3f s, p99 %.3f s; searches ended by the deadline: %d\n",
              Mean(queued), oaipp::bench::Quantile(queued, 0.99), cut);
  std::vector<double> first_generations, waits;
  int refusals = 0;
  for (const MissionResult& m : r.missions) {
    if (!m.finished) continue;
    if (!m.plan_stats.empty()) first_generations.push_back(m.plan_stats.front()[3]);
    waits.push_back(m.take_off_wait_s);
    refusals += m.take_off_refusals;
  }
  std::printf("first plans: mean %.1f generations\n", Mean(first_generations));
  std::printf(
      "take-off (creation to the first path, on the ground): p50 %.2f s, p99 %.2f s, max %.2f s; "
      "%d first plans refused by take-off pacing\n",
      oaipp::bench::Quantile(waits, 0.5), oaipp::bench::Quantile(waits, 0.99),
      oaipp::bench::Quantile(waits, 1.0), refusals);
  if (pace == "real_time") {
    std::vector<double> hovers;
    for (const MissionResult& m : r.missions) {
      if (m.finished) hovers.push_back(m.hover_s);
    }
    std::printf("in the air waiting for the next path, per mission: mean %.2f s, max %.2f s\n",
                Mean(hovers), oaipp::bench::Quantile(hovers, 1.0));
  }
  if (absl::GetFlag(FLAGS_replan_cut_within_s) > 0.0) {
    int left = 0;
    for (const MissionResult& m : r.missions) left += m.finished ? m.cut_replans : 0;
    std::printf("cut plans left at a shot and replanned from the moving state: %d\n", left);
  }
  std::printf("memory per mission (map + its share of the ESDF, as reported): %.1f MB\n",
              r.bytes_per_mission / 1e6);
  std::printf("peak RSS of the process (server and clients): %.0f MB, %.1f MB per mission\n",
              r.peak_rss_kb / 1e3, r.peak_rss_kb / 1e3 / missions);
  const std::vector<double> rses = Rses(r);
  std::vector<double> found;
  for (const MissionResult& m : r.missions) {
    if (m.finished) found.push_back(m.found);
  }
  std::printf("E1 RSE at %.0f s: mean %.3f, standard error %.3f; people found: mean %.2f of 7\n",
              budget, Mean(rses), StdErr(rses), Mean(found));
}

nlohmann::json ToJson(LoadResult& r, const std::string& pace) {
  nlohmann::json j;
  j["label"] = r.label;
  j["pace"] = pace;
  j["wall_s"] = r.wall_s;
  j["peak_rss_mb"] = r.peak_rss_kb / 1e3;
  j["bytes_per_mission"] = r.bytes_per_mission;
  nlohmann::json methods = nlohmann::json::object();
  for (const std::string& method : r.latencies.Methods()) {
    methods[method] = {{"calls", r.latencies.Count(method)},
                       {"errors", r.latencies.Errors(method)},
                       {"p50_ms", r.latencies.Percentile(method, 0.5)},
                       {"p99_ms", r.latencies.Percentile(method, 0.99)},
                       {"max_ms", r.latencies.Percentile(method, 1.0)}};
  }
  j["methods"] = methods;
  nlohmann::json missions = nlohmann::json::array();
  for (const MissionResult& m : r.missions) {
    missions.push_back({{"finished", m.finished},
                        {"rse", m.rse},
                        {"found", m.found},
                        {"plans", m.plans},
                        // [asked_s, wall_s, evaluations, generations, share,
                        //  queued_s, ended_by_deadline]
                        {"plan_stats", m.plan_stats},
                        {"take_off_wait_s", m.take_off_wait_s},
                        {"take_off_refusals", m.take_off_refusals},
                        {"hover_s", m.hover_s},
                        {"wall_s", m.wall_s}});
  }
  j["missions"] = missions;
  const std::vector<double> rses = Rses(r);
  j["rse_mean"] = Mean(rses);
  j["rse_stderr"] = StdErr(rses);
  nlohmann::json calls = nlohmann::json::array();
  for (const Latencies::Call& c : r.latencies.Calls()) {
    calls.push_back({c.start_s, c.method, c.ms, c.ok});
  }
  j["calls"] = calls;  // [start_s, method, ms, ok]
  return j;
}

// Flags of oaipp-server whose default differs here: no metrics endpoint
// (the load runs beside whatever else uses its port), sqlite files under
// /tmp and fewer log lines. The command line still overrides each.
// Everything else is oaipp-server's own default.
void SetLoadDefaults() {
  const std::pair<const char*, const char*> defaults[] = {
      {"metrics_listen", ""}, {"data_dir", "/tmp/oaipp-server-load"}, {"log_level", "warn"}};
  for (const auto& [name, value] : defaults) {
    absl::CommandLineFlag* flag = absl::FindCommandLineFlag(name);
    std::string error;
    if (flag == nullptr || !flag->ParseFrom(value, &error)) {
      std::fprintf(stderr, "server_load: cannot set --%s's default: %s\n", name, error.c_str());
      std::exit(1);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  // As the server does: the numeric libraries' threads (server/library_settings.h).
  if (!oaipp::server::SetUpNumericLibrariesOrSay()) return 1;
  absl::SetProgramUsageMessage(
      "Many E1 missions at once on one server in process; takes oaipp-server's flags too "
      "(--help lists them).");
  SetLoadDefaults();
  absl::ParseCommandLine(argc, argv);
  // --planning_queue holds a plan of every mission (one each is in flight)
  // unless given: oaipp-server's default already does for up to 128.
  const bool queue_given = std::any_of(argv + 1, argv + argc, [](const char* arg) {
    return absl::StartsWith(arg, "--planning_queue") || absl::StartsWith(arg, "-planning_queue");
  });
  if (!queue_given &&
      absl::GetFlag(FLAGS_missions) > oaipp::server::ServerOptionsFromFlags().planning_queue) {
    std::string error;
    (void)absl::FindCommandLineFlag("planning_queue")
        ->ParseFrom(std::to_string(absl::GetFlag(FLAGS_missions)), &error);
  }
  const oaipp::server::ServerOptions options = oaipp::server::ServerOptionsFromFlags();
  spdlog::set_level(spdlog::level::from_str(options.log_level));
  const std::string pace = absl::GetFlag(FLAGS_pace);
  if (pace != "real_time" && pace != "as_fast") {
    std::fprintf(stderr, "--pace: real_time or as_fast, got %s\n", pace.c_str());
    return 2;
  }
  if (absl::Status valid = options.Validate(); !valid.ok()) {
    std::fprintf(stderr, "%s\n", std::string(valid.message()).c_str());
    return 2;
  }
  const int missions = absl::GetFlag(FLAGS_missions);
  const double budget = absl::GetFlag(FLAGS_budget_s);
  if (missions < 1 || !(budget > 0) || !(absl::GetFlag(FLAGS_first_plan_budget_s) >= 0.0) ||
      !(absl::GetFlag(FLAGS_launch_spread_s) >= 0.0) ||
      !(absl::GetFlag(FLAGS_replan_cut_within_s) >= 0.0)) {
    std::fprintf(stderr,
                 "--missions must be >= 1, --budget_s > 0, --first_plan_budget_s >= 0, "
                 "--launch_spread_s >= 0 and --replan_cut_within_s >= 0\n");
    return 2;
  }
  std::vector<std::unique_ptr<LoadResult>> runs;
  std::unique_ptr<oaipp::server::testing::PostgresInstance> postgres;
  for (std::string kind : absl::GetFlag(FLAGS_stores)) {
    const std::string label = kind;
    if (kind == "postgresql") {
      if (postgres == nullptr) {
        postgres = std::make_unique<oaipp::server::testing::PostgresInstance>();
        if (!oaipp::server::testing::PostgresInstance::Available() || !postgres->Start()) {
          std::fprintf(stderr, "cannot start PostgreSQL 15 (deploy/install-deps.sh installs it)\n");
          return 1;
        }
      }
      const std::string database = absl::StrCat("load", runs.size());
      if (!postgres->CreateDatabase(database)) return 1;
      kind = postgres->uri(database);
    }
    const std::string dir = absl::StrCat(options.data_dir, "/run-", runs.size(), "-", getpid());
    std::filesystem::remove_all(dir);
    std::printf("== store: %s\n", oaipp::server::DescribeStore(kind, dir).c_str());
    std::fflush(stdout);
    runs.push_back(std::make_unique<LoadResult>());
    runs.back()->label = label;
    oaipp::server::ServerOptions run = options;
    run.store = kind;
    run.data_dir = dir;
    RunLoad(run, /*alone=*/false, *runs.back());
    Print(*runs.back(), missions, budget, pace, options.planning_threads);
    std::filesystem::remove_all(dir);
  }
  if (runs.size() > 1) {
    std::printf("\nwall time against %s:\n", runs.front()->label.c_str());
    for (const auto& run : runs) {
      std::printf("  %-12.12s %8.1f s  %.3f\n", run->label.c_str(), run->wall_s,
                  run->wall_s / runs.front()->wall_s);
    }
  }
  std::unique_ptr<LoadResult> alone;
  if (absl::GetFlag(FLAGS_compare_alone)) {
    std::printf("\n== the same missions one at a time (memory store, nothing shed)\n");
    std::fflush(stdout);
    alone = std::make_unique<LoadResult>();
    alone->label = "alone";
    oaipp::server::ServerOptions one_by_one = options;
    one_by_one.store = "memory";
    RunLoad(one_by_one, /*alone=*/true, *alone);
    Print(*alone, missions, budget, "one at a time", options.planning_threads);
    const std::vector<double> together = Rses(*runs.front());
    const std::vector<double> apart = Rses(*alone);
    std::printf(
        "mean RSE together %.3f against alone %.3f: difference %.3f, %.2f standard errors "
        "(of the missions alone)\n",
        Mean(together), Mean(apart), Mean(together) - Mean(apart),
        StdErr(apart) > 0 ? (Mean(together) - Mean(apart)) / StdErr(apart) : 0.0);
    // Mission by mission (same seed in both runs): the spread of the
    // difference says how much of it one run's luck can explain.
    std::vector<double> differences;
    for (std::size_t m = 0; m < alone->missions.size(); ++m) {
      const MissionResult& a = runs.front()->missions[m];
      const MissionResult& b = alone->missions[m];
      if (a.finished && b.finished) differences.push_back(a.rse - b.rse);
    }
    std::printf("mission by mission: mean difference %.3f, standard error %.3f (%zu pairs)\n",
                Mean(differences), StdErr(differences), differences.size());
  }
  if (const std::string path = absl::GetFlag(FLAGS_json); !path.empty()) {
    nlohmann::json j;
    j["missions"] = missions;
    j["budget_s"] = budget;
    j["planning_threads"] = options.planning_threads;
    j["shed_above"] = options.shed_above;
    j["shed_after_wait_s"] = options.shed_after_wait_s;
    j["plan_latency_s"] = options.plan_latency_s;
    j["launch_spread_s"] = absl::GetFlag(FLAGS_launch_spread_s);
    j["take_off_plans"] = options.max_take_off_plans;
    j["take_off_patience_s"] = options.take_off_patience_s;
    j["first_plan_budget_s"] = absl::GetFlag(FLAGS_first_plan_budget_s);
    j["replan_cut_within_s"] = absl::GetFlag(FLAGS_replan_cut_within_s);
    j["generations"] = absl::GetFlag(FLAGS_generations);
    j["stall_generations"] = absl::GetFlag(FLAGS_stall_generations);
    j["stall_tolerance"] = absl::GetFlag(FLAGS_stall_tolerance);
    j["dense_backend"] = runs.empty() ? "" : runs.front()->dense_backend;
    j["objective_precision"] = options.objective_precision;
    nlohmann::json list = nlohmann::json::array();
    for (auto& run : runs) list.push_back(ToJson(*run, pace));
    j["runs"] = list;
    if (alone != nullptr) j["alone"] = ToJson(*alone, "one at a time");
    std::ofstream file(path);
    file << j.dump(1) << "\n";
    if (!file) {
      std::fprintf(stderr, "cannot write %s\n", path.c_str());
      return 1;
    }
    std::printf("figures and every call written to %s\n", path.c_str());
  }
  return 0;
}
