#include "core/planning/large_field.h"

#include "core/common/status_macros.h"

namespace oaipp {

absl::StatusOr<PlannedPath> PlanInWindow(Planner& planner, const SparseGpMap& map,
                                         PlanningContext context, const UavState& state,
                                         absl::Time deadline, const LargeFieldPlanning& options) {
  OAIPP_ASSIGN_OR_RETURN(FieldWindow window, WindowAround(map.grid(), state.position_W.head<2>(),
                                                          options.half_width_m));
  OAIPP_ASSIGN_OR_RETURN(GpMap local, WindowMap(map, window, options.window, options.backend));
  context.map = &local;
  // A conditioned-covariance cache belongs to one map: not this window's.
  context.conditioned = nullptr;
  return planner.Plan(context, state, deadline);
}

}  // namespace oaipp
