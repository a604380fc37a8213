#include "core/planning/planners.h"

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"

namespace oaipp {

std::string PlannerKindName(PlannerKind kind) {
  switch (kind) {
    case PlannerKind::kOaIpp:
      return "oaipp";
    case PlannerKind::kOaIppNonAdaptive:
      return "oaipp_nonadaptive";
    case PlannerKind::kLawnmower:
      return "lawnmower";
    case PlannerKind::kRandom:
      return "random";
  }
  return "unknown";
}

absl::StatusOr<PlannerKind> ParsePlannerKind(absl::string_view name) {
  for (PlannerKind k : {PlannerKind::kOaIpp, PlannerKind::kOaIppNonAdaptive,
                        PlannerKind::kLawnmower, PlannerKind::kRandom}) {
    if (name == PlannerKindName(k)) return k;
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "planner: unknown kind '", name, "' (expected oaipp, oaipp_nonadaptive, lawnmower, random)"));
}

absl::StatusOr<std::unique_ptr<Planner>> MakePlanner(const PlannerConfig& config) {
  switch (config.kind) {
    case PlannerKind::kOaIpp:
    case PlannerKind::kOaIppNonAdaptive: {
      OaIppConfig c = config.oaipp;
      c.common = config.common;
      c.common.information.kind = config.kind == PlannerKind::kOaIpp ? ObjectiveKind::kAdaptive
                                                                     : ObjectiveKind::kNonAdaptive;
      OAIPP_RETURN_IF_ERROR(c.Validate());
      return std::make_unique<OaIppPlanner>(std::move(c));
    }
    case PlannerKind::kLawnmower: {
      LawnmowerConfig c = config.lawnmower;
      c.common = config.common;
      OAIPP_RETURN_IF_ERROR(c.Validate());
      return std::make_unique<LawnmowerPlanner>(std::move(c));
    }
    case PlannerKind::kRandom: {
      RandomConfig c = config.random;
      c.common = config.common;
      OAIPP_RETURN_IF_ERROR(c.Validate());
      return std::make_unique<RandomPlanner>(std::move(c));
    }
  }
  return absl::InvalidArgumentError("planner.kind: unknown");
}

}  // namespace oaipp
