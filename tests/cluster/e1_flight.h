// One E1 mission flown through the client library, as oaipp-client run
// flies it (plan, fly the path in simulated time, send the perfect
// detector's labels at each shot, replan until the budget is spent), keeping
// every measurement the service acknowledged, in order, for a replay.
#pragma once

#include <algorithm>
#include <chrono>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "client/client.h"
#include "tests/bench/server/e1_mission.h"

namespace oaipp::cluster_testing {

struct E1Flight {
  std::string name;  // "missions/{id}"
  // CMA-ES generations per plan (E1's are 45; fewer cost less CPU where
  // plan quality is not what is tested).
  int generations = 45;
  std::vector<v1::AddMeasurementRequest> acknowledged = {};
  int plans = 0;
  double mission_time_s = 0.0;
  // Every replica that answered one of the mission's calls.
  std::set<std::string> replicas = {};
  // Called after every acknowledged call (for a test's kill schedule).
  std::function<void()> on_ack = nullptr;
  // Called after every call with its method, wall time (retries included)
  // and outcome (for benchmarks).
  std::function<void(const char* method, double ms, bool ok)> on_call = nullptr;
};

// `call()` timed for flight.on_call.
template <typename Call>
auto Timed(E1Flight& flight, const char* method, Call call) {
  const auto start = std::chrono::steady_clock::now();
  auto result = call();
  if (flight.on_call) {
    flight.on_call(
        method,
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count(),
        result.ok());
  }
  return result;
}

// Client options patient enough for a replica to die, the proxy to notice
// and another replica to take the mission over: UNAVAILABLE and CANCELLED
// are retried for about attempts x max_backoff.
inline client::ClientOptions PatientClient(int attempts, absl::Duration first_backoff,
                                           absl::Duration max_backoff) {
  client::ClientOptions options;
  options.plan_timeout = absl::Seconds(300);
  options.max_attempts = attempts;
  options.first_backoff = first_backoff;
  options.max_backoff = max_backoff;
  return options;
}

// The E1 spec as this mission flies it: seed and budget set.
inline v1::MissionSpec E1FlightSpec(std::uint32_t seed, double budget_s, int generations = 45) {
  v1::MissionSpec spec = bench::E1Spec(generations);
  spec.mutable_planner()->set_seed(seed);
  spec.set_budget_s(budget_s);
  return spec;
}

// Flies mission `id` to the end of its budget; the first error any call
// returns (after the library's retries of UNAVAILABLE and CANCELLED) stops
// the flight.
inline absl::Status FlyE1(client::Client& client, const std::string& id, std::uint32_t seed,
                          double budget_s, E1Flight& flight) {
  flight.name = "missions/" + id;
  const auto acked = [&] {
    if (const std::string r = client.last_replica(); !r.empty()) flight.replicas.insert(r);
    if (flight.on_ack) flight.on_ack();
  };
  absl::StatusOr<v1::Mission> created = Timed(flight, "CreateMission", [&] {
    return client.CreateMission(E1FlightSpec(seed, budget_s, flight.generations), id);
  });
  if (!created.ok()) return created.status();
  acked();
  v1::UavState state = created->spec().start();
  while (state.mission_time_s() < budget_s) {
    v1::PlanPathRequest plan;
    plan.set_name(flight.name);
    *plan.mutable_state() = state;
    absl::StatusOr<v1::PlanPathResponse> path =
        Timed(flight, "PlanPath", [&] { return client.PlanPath(plan); });
    if (!path.ok()) return path.status();
    acked();
    ++flight.plans;
    const double fly = std::min(path->trajectory().duration_s(), budget_s - state.mission_time_s());
    for (const auto& pose : path->measurement_poses()) {
      if (pose.t_s() > fly) break;
      v1::AddMeasurementRequest shot =
          bench::E1Measurement(flight.name, pose.position_m(), pose.mission_time_s());
      shot.set_request_id(absl::StrCat(id, "-shot-", flight.acknowledged.size()));
      absl::StatusOr<v1::AddMeasurementResponse> fused =
          Timed(flight, "AddMeasurement", [&] { return client.AddMeasurement(shot); });
      if (!fused.ok()) return fused.status();
      flight.acknowledged.push_back(shot);
      acked();
    }
    const auto& last = path->trajectory().samples(path->trajectory().samples_size() - 1);
    *state.mutable_position_m() = last.position_m();
    state.set_mission_time_s(state.mission_time_s() + path->trajectory().duration_s());
  }
  flight.mission_time_s = state.mission_time_s();
  return absl::OkStatus();
}

}  // namespace oaipp::cluster_testing
