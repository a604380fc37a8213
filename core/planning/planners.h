// Choosing a planner by kind (what the service and the client use).
//
//   PlannerConfig config{.kind = PlannerKind::kLawnmower};
//   OAIPP_ASSIGN_OR_RETURN(std::unique_ptr<Planner> planner, MakePlanner(config));
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "core/planning/baseline_planners.h"
#include "core/planning/oaipp_planner.h"
#include "core/planning/return_home.h"

namespace oaipp {

// kOaIppDetection: OA-IPP with the detection objective (a search from a
// probability prior, docs/method.md §6.6).
enum class PlannerKind { kOaIpp, kOaIppNonAdaptive, kLawnmower, kRandom, kOaIppDetection };

[[nodiscard]] std::string PlannerKindName(PlannerKind kind);
// "oaipp", "oaipp_nonadaptive", "lawnmower", "random", "oaipp_detection";
// InvalidArgument otherwise.
[[nodiscard]] absl::StatusOr<PlannerKind> ParsePlannerKind(absl::string_view name);

// The objective a planner of `kind` optimises or reports: the trace
// reduction for kOaIppNonAdaptive, the detection objective for
// kOaIppDetection, the adaptive UCB objective otherwise.
[[nodiscard]] ObjectiveKind ObjectiveFor(PlannerKind kind);

struct PlannerConfig {
  PlannerKind kind = PlannerKind::kOaIpp;
  // Settings every kind shares. Its information.kind is ignored: MakePlanner
  // takes it from ObjectiveFor(kind).
  PlannerCommon common = {};
  // The kind's own settings; only the one matching `kind` is used.
  OaIppConfig oaipp = {};
  LawnmowerConfig lawnmower = {};
  RandomConfig random = {};
  // The mission's home and reserve (MissionSpec.home); unset: plans need not
  // leave a way home.
  std::optional<HomeConfig> home = std::nullopt;
};

// A fresh planner (its own state) for one mission, wrapped in a
// StopFirstPlanner (core/planning/stop_first.h) so that it also answers from
// moving starts it cannot plan from directly, and, with a home, in a
// ReturnHomePlanner around that. The objective follows `kind`
// (ObjectiveFor). InvalidArgument for a bad configuration.
[[nodiscard]] absl::StatusOr<std::unique_ptr<Planner>> MakePlanner(const PlannerConfig& config);

}  // namespace oaipp
