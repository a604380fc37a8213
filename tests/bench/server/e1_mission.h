// The E1 benchmark mission for the service benchmarks, read from the
// committed scenario file (client/scenarios/e1.json, the one definition of
// E1 that speaks the API), and the measurements a perfect detector sends.
#pragma once

#include <cstdlib>
#include <iostream>
#include <string>

#include "api/geometry.h"
#include "api/measurement.h"
#include "oaipp/v1/mission_service.pb.h"
#include "sim/scenario.h"
#include "sim/simulation.h"

namespace oaipp::bench {

// The E1 scenario and its simulated world, loaded once.
struct E1World {
  v1::Scenario scenario;
  sim::Simulation simulation;
};
inline const E1World& E1() {
  static const E1World* world = [] {
    absl::StatusOr<v1::Scenario> scenario = sim::LoadScenarioFile(OAIPP_SCENARIO_DIR "/e1.json");
    absl::StatusOr<sim::Simulation> simulation =
        scenario.ok() ? sim::Simulation::Create(*scenario)
                      : absl::StatusOr<sim::Simulation>(scenario.status());
    if (!simulation.ok()) {
      std::cerr << "E1 scenario: " << simulation.status() << "\n";
      std::exit(2);
    }
    return new E1World{*std::move(scenario), *std::move(simulation)};
  }();
  return *world;
}

// The E1 mission spec with `generations` CMA-ES generations.
inline v1::MissionSpec E1Spec(int generations = 45) {
  v1::MissionSpec spec = E1().scenario.mission();
  spec.mutable_planner()->set_generations(generations);
  return spec;
}

// The labels a perfect detector gives from a camera at p over its visible
// footprint: 1 on the cells the people cover, 0 elsewhere.
inline v1::AddMeasurementRequest E1Measurement(const std::string& name, const v1::Vector3& p,
                                               double time_s) {
  const Vec3 p_W = api::FromProto(p);
  api::MeasurementInput input{.mission_time_s = time_s, .pose = CameraPose{p_W, 0.0}};
  input.labels = E1().simulation.TruthLabels(p_W);
  v1::AddMeasurementRequest request;
  request.set_name(name);
  api::MeasurementToProto(input, &request);
  return request;
}

}  // namespace oaipp::bench
