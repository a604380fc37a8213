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

ObjectiveKind ObjectiveFor(PlannerKind kind) {
  return kind == PlannerKind::kOaIppNonAdaptive ? ObjectiveKind::kNonAdaptive
                                                : ObjectiveKind::kAdaptive;
}

absl::StatusOr<std::unique_ptr<Planner>> MakePlanner(const PlannerConfig& config) {
  PlannerCommon common = config.common;
  common.information.kind = ObjectiveFor(config.kind);
  OAIPP_RETURN_IF_ERROR(common.Validate());
  switch (config.kind) {
    case PlannerKind::kOaIpp:
    case PlannerKind::kOaIppNonAdaptive:
      OAIPP_RETURN_IF_ERROR(config.oaipp.Validate());
      return std::make_unique<OaIppPlanner>(common, config.oaipp);
    case PlannerKind::kLawnmower:
      OAIPP_RETURN_IF_ERROR(config.lawnmower.Validate());
      return std::make_unique<LawnmowerPlanner>(common, config.lawnmower);
    case PlannerKind::kRandom:
      OAIPP_RETURN_IF_ERROR(config.random.Validate());
      return std::make_unique<RandomPlanner>(common, config.random);
  }
  return absl::InvalidArgumentError("planner.kind: unknown");
}

}  // namespace oaipp
