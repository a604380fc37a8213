// Rounds of a team's plans through the whole service, in process: every UAV
// of a team scenario (client/scenarios/e5-team8.json by default) asks for
// its next path at once, and the round lasts until the last of them is
// answered. A mission's plans are made one at a time (docs/teams.md), so a
// round costs about the sum of its plans. Rounds are --round_s apart on the
// mission clock: every UAV asks from where its last path has it then
// (moving, or at rest at the path's end), and the shots its path took
// before then are fused in between (the simulated detector's labels).
//
// It prints the median and 95th percentile of the round's latency and of a
// single plan's, the largest planner time and the plan versions seen, for
// docs/benchmarks.md.
//
//   build/tests/bench/server/team_round --rounds=10
//   build/tests/bench/server/team_round --rounds=10 --flight_budget_s=3600
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "api/geometry.h"
#include "api/measurement.h"
#include "api/plan.h"
#include "grpcpp/grpcpp.h"
#include "oaipp/v1/mission_service.grpc.pb.h"
#include "server/flags/flags.h"
#include "server/library_settings.h"
#include "server/server.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "tests/bench/server/latencies.h"

ABSL_FLAG(std::string, scenario, OAIPP_SCENARIO_DIR "/e5-team8.json", "a team scenario");
ABSL_FLAG(int, rounds, 10, "rounds of plans, one per UAV each (within the budget)");
ABSL_FLAG(double, planning_budget_s, 0.0, "each plan's planning_budget_s; 0: unset");
ABSL_FLAG(double, flight_budget_s, 0.0,
          "the mission's budget_s; 0: the scenario's (the planner's horizon follows what is "
          "left of it)");
ABSL_FLAG(double, round_s, 20.0 / 3.0,
          "mission time between rounds (default: E5's shot period, 1 / 0.15 Hz)");

namespace oaipp {
namespace {

using Clock = std::chrono::steady_clock;
using bench::MsSince;

int Run() {
  absl::StatusOr<v1::Scenario> scenario = sim::LoadScenarioFile(absl::GetFlag(FLAGS_scenario));
  absl::StatusOr<sim::Simulation> simulation =
      scenario.ok() ? sim::Simulation::Create(*scenario)
                    : absl::StatusOr<sim::Simulation>(scenario.status());
  if (!simulation.ok()) {
    std::cerr << "scenario: " << simulation.status() << "\n";
    return 2;
  }
  const int team = scenario->mission().team_size();
  if (team < 2) {
    std::cerr << "scenario: needs a team (mission.team) of 2 or more\n";
    return 2;
  }
  // The server's own flags (--plan_latency_s, --shed_above,
  // --planning_threads, --dense_backend, ...) with their own defaults, as
  // oaipp-server composes itself; only where it listens, the queue (a whole
  // round fits) and the store (in memory) are this benchmark's.
  server::ServerOptions options = server::ServerOptionsFromFlags();
  options.listen = "127.0.0.1:0";  // the rounds use InProcessChannel()
  options.metrics_listen = "";
  options.web_port = 0;
  options.planning_queue = std::max(options.planning_queue, 2 * team);
  options.store = "memory";
  absl::StatusOr<std::unique_ptr<server::Server>> server = server::Server::Start(options);
  if (!server.ok()) {
    std::cerr << "server: " << server.status() << "\n";
    return 2;
  }
  auto stub = v1::MissionService::NewStub((*server)->InProcessChannel());
  v1::Mission mission;
  {
    grpc::ClientContext context;
    v1::CreateMissionRequest request;
    *request.mutable_spec() = scenario->mission();
    if (absl::GetFlag(FLAGS_flight_budget_s) > 0) {
      request.mutable_spec()->set_budget_s(absl::GetFlag(FLAGS_flight_budget_s));
    }
    if (const grpc::Status s = stub->CreateMission(&context, request, &mission); !s.ok()) {
      std::cerr << "CreateMission: " << s.error_message() << "\n";
      return 1;
    }
  }
  std::vector<v1::UavState> states;
  // Each UAV's last path.
  std::vector<v1::PlanPathResponse> paths(static_cast<std::size_t>(team));
  const double round_s = absl::GetFlag(FLAGS_round_s);
  double now_s = mission.spec().team(0).start().mission_time_s();
  for (const v1::TeamMember& m : mission.spec().team()) states.push_back(m.start());
  std::mt19937_64 rng(scenario->seed());
  std::vector<double> round_ms, plan_ms, evaluations;
  int cut_short = 0;  // plans whose search a deadline or the shedding ended
  double planner_max_s = 0.0;
  std::int64_t last_version = 0;
  const int rounds = absl::GetFlag(FLAGS_rounds);
  const double budget_s = absl::GetFlag(FLAGS_planning_budget_s);
  std::printf(
      "%s: %d UAVs, %d rounds, %d planning threads, planning_budget_s %s, plan_latency_s %s, "
      "shed_above %g, %s, %s precision\n",
      scenario->name().c_str(), team, rounds, options.planning_threads,
      budget_s > 0 ? std::to_string(budget_s).c_str() : "unset",
      options.plan_latency_s > 0 ? std::to_string(options.plan_latency_s).c_str() : "unset",
      options.shed_above, (*server)->dense_backend().name().c_str(),
      options.objective_precision.c_str());
  for (int round = 0; round < rounds; ++round) {
    std::vector<grpc::Status> status(static_cast<std::size_t>(team));
    std::vector<double> ms(static_cast<std::size_t>(team));
    std::vector<std::thread> askers;
    const Clock::time_point start = Clock::now();
    for (int i = 0; i < team; ++i) {
      askers.emplace_back([&, i] {
        const auto k = static_cast<std::size_t>(i);
        v1::PlanPathRequest request;
        request.set_name(mission.name());
        request.set_uav_id(mission.spec().team(i).uav_id());
        *request.mutable_state() = states[k];
        if (budget_s > 0) request.set_planning_budget_s(budget_s);
        grpc::ClientContext context;
        const Clock::time_point asked = Clock::now();
        status[k] = stub->PlanPath(&context, request, &paths[k]);
        ms[k] = MsSince(asked);
      });
    }
    for (std::thread& t : askers) t.join();
    round_ms.push_back(MsSince(start));
    const double next_round_s = now_s + round_s;
    for (int i = 0; i < team; ++i) {
      const auto k = static_cast<std::size_t>(i);
      if (!status[k].ok()) {
        std::cerr << "PlanPath " << mission.spec().team(i).uav_id() << ": "
                  << status[k].error_message() << "\n";
        return 1;
      }
      plan_ms.push_back(ms[k]);
      evaluations.push_back(static_cast<double>(paths[k].stats().evaluations()));
      if (paths[k].stats().stop_reason() == "deadline" ||
          paths[k].stats().search_fraction() < 1.0) {
        ++cut_short;
      }
      if (const v1::PlannerStats& st = paths[k].stats(); st.wall_time_s() > 1.0) {
        std::printf(
            "    %s: planner %.2f s, %lld evaluations, %d generations, stop %s, "
            "stop-first %.2f s\n",
            mission.spec().team(i).uav_id().c_str(), st.wall_time_s(),
            static_cast<long long>(st.evaluations()), st.generations(), st.stop_reason().c_str(),
            st.stop_first_s());
      }
      planner_max_s = std::max(planner_max_s, paths[k].stats().wall_time_s());
      last_version = std::max(last_version, paths[k].plan_version());
      for (const v1::MeasurementPose& shot : paths[k].measurement_poses()) {
        if (shot.mission_time_s() >= next_round_s) break;  // replanned before it
        const Vec3 camera = api::FromProto(shot.position_m());
        api::MeasurementInput input{.mission_time_s = shot.mission_time_s(),
                                    .pose = CameraPose{camera, 0.0},
                                    .uav_id = mission.spec().team(i).uav_id()};
        absl::StatusOr<CellLabels> labels =
            simulation->Labels(camera, simulation->Detect(camera, rng));
        if (!labels.ok()) {
          std::cerr << "labels: " << labels.status() << "\n";
          return 1;
        }
        input.labels = *labels;
        v1::AddMeasurementRequest add;
        add.set_name(mission.name());
        api::MeasurementToProto(input, &add);
        v1::AddMeasurementResponse added;
        grpc::ClientContext context;
        if (const grpc::Status s = stub->AddMeasurement(&context, add, &added); !s.ok()) {
          std::cerr << "AddMeasurement: " << s.error_message() << "\n";
          return 1;
        }
      }
    }
    // The next round: every UAV where its path has it then (moving, or at
    // rest at its end).
    now_s = next_round_s;
    for (int i = 0; i < team; ++i) {
      const auto k = static_cast<std::size_t>(i);
      absl::StatusOr<PolynomialTrajectory> traj = api::TrajectoryFromProto(paths[k].trajectory());
      if (!traj.ok()) {
        std::cerr << "trajectory: " << traj.status() << "\n";
        return 1;
      }
      const double t = now_s - paths[k].start_mission_s();
      v1::UavState& state = states[k];
      *state.mutable_position_m() = api::ToProto(traj->Position(t));
      if (t < traj->Duration()) {
        *state.mutable_velocity_m_s() = api::ToProto(traj->Velocity(t));
        *state.mutable_acceleration_m_s2() = api::ToProto(traj->Acceleration(t));
      } else {
        state.clear_velocity_m_s();
        state.clear_acceleration_m_s2();
      }
      state.set_mission_time_s(now_s);
    }
    std::printf("  round %2d at t = %6.1f s: %7.0f ms\n", round + 1, now_s - round_s,
                round_ms.back());
    std::fflush(stdout);
  }
  std::printf(
      "round of %d plans: median %.0f ms, p95 %.0f ms; one plan: median %.0f ms, p95 %.0f ms; "
      "planner at most %.2f s; plan_version reached %lld; evaluations a plan: median %.0f; "
      "searches cut short: %d of %zu\n",
      team, bench::Quantile(round_ms, 0.5), bench::Quantile(round_ms, 0.95),
      bench::Quantile(plan_ms, 0.5), bench::Quantile(plan_ms, 0.95), planner_max_s,
      static_cast<long long>(last_version), bench::Quantile(evaluations, 0.5), cut_short,
      plan_ms.size());
  return 0;
}

}  // namespace
}  // namespace oaipp

int main(int argc, char** argv) {
  // As the server does: the numeric libraries' threads (server/library_settings.h).
  if (!oaipp::server::SetUpNumericLibrariesOrSay()) return 1;
  absl::SetProgramUsageMessage(
      "Rounds of a team's plans through the service in process; takes oaipp-server's flags "
      "too (--helpfull lists them).");
  absl::ParseCommandLine(argc, argv);
  return oaipp::Run();
}
