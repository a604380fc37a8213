#include "core/planning/planners.h"

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"
#include "core/planning/stop_first.h"

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
    case PlannerKind::kOaIppDetection:
      return "oaipp_detection";
  }
  return "unknown";
}

absl::StatusOr<PlannerKind> ParsePlannerKind(absl::string_view name) {
  for (PlannerKind k :
       {PlannerKind::kOaIpp, PlannerKind::kOaIppNonAdaptive, PlannerKind::kLawnmower,
        PlannerKind::kRandom, PlannerKind::kOaIppDetection}) {
    if (name == PlannerKindName(k)) return k;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("planner: unknown kind '", name,
                   "' (expected oaipp, oaipp_nonadaptive, lawnmower, random, oaipp_detection)"));
}

ObjectiveKind ObjectiveFor(PlannerKind kind) {
  switch (kind) {
    case PlannerKind::kOaIppNonAdaptive:
      return ObjectiveKind::kNonAdaptive;
    case PlannerKind::kOaIppDetection:
      return ObjectiveKind::kDetection;
    case PlannerKind::kOaIpp:
    case PlannerKind::kLawnmower:
    case PlannerKind::kRandom:
      break;
  }
  return ObjectiveKind::kAdaptive;
}

absl::StatusOr<std::unique_ptr<Planner>> MakePlanner(const PlannerConfig& config) {
  PlannerCommon common = config.common;
  common.information.kind = ObjectiveFor(config.kind);
  OAIPP_RETURN_IF_ERROR(common.Validate());
  std::unique_ptr<Planner> planner;
  switch (config.kind) {
    case PlannerKind::kOaIpp:
    case PlannerKind::kOaIppNonAdaptive:
    case PlannerKind::kOaIppDetection:
      OAIPP_RETURN_IF_ERROR(config.oaipp.Validate());
      planner = std::make_unique<OaIppPlanner>(common, config.oaipp);
      break;
    case PlannerKind::kLawnmower:
      OAIPP_RETURN_IF_ERROR(config.lawnmower.Validate());
      planner = std::make_unique<LawnmowerPlanner>(common, config.lawnmower);
      break;
    case PlannerKind::kRandom:
      OAIPP_RETURN_IF_ERROR(config.random.Validate());
      planner = std::make_unique<RandomPlanner>(common, config.random);
      break;
  }
  if (planner == nullptr) return absl::InvalidArgumentError("planner.kind: unknown");
  // Every kind may stop first from a moving start it cannot plan from.
  planner = std::make_unique<StopFirstPlanner>(std::move(planner), common.limits);
  if (!config.home.has_value()) return planner;
  OAIPP_RETURN_IF_ERROR(config.home->Validate());
  return std::make_unique<ReturnHomePlanner>(std::move(planner), common, *config.home);
}

}  // namespace oaipp
