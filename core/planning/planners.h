// Choosing a planner by kind (what the service and the client use).
//
//   PlannerConfig config{.kind = PlannerKind::kLawnmower};
//   OAIPP_ASSIGN_OR_RETURN(std::unique_ptr<Planner> planner, MakePlanner(config));
#pragma once

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "core/planning/baseline_planners.h"
#include "core/planning/oaipp_planner.h"

namespace oaipp {

enum class PlannerKind { kOaIpp, kOaIppNonAdaptive, kLawnmower, kRandom };

[[nodiscard]] std::string PlannerKindName(PlannerKind kind);
// "oaipp", "oaipp_nonadaptive", "lawnmower", "random"; InvalidArgument otherwise.
[[nodiscard]] absl::StatusOr<PlannerKind> ParsePlannerKind(absl::string_view name);

struct PlannerConfig {
  PlannerKind kind = PlannerKind::kOaIpp;
  // The kind's own section is used; common settings come from `common`.
  PlannerCommon common = {};
  OaIppConfig oaipp = {};
  LawnmowerConfig lawnmower = {};
  RandomConfig random = {};
};

// A fresh planner (its own state) for one mission. OA-IPP's objective kind
// follows `kind`. InvalidArgument for a bad configuration.
[[nodiscard]] absl::StatusOr<std::unique_ptr<Planner>> MakePlanner(const PlannerConfig& config);

}  // namespace oaipp
