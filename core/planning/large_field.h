// Planning on a field too large for a dense map (docs/method.md §3.10): the
// planner runs unchanged on a dense window of the sparse map around the UAV
// (core/mapping/field_window.h), so its waypoints, footprints and
// objectives stay within half_width_m of where the UAV is.
//
//   LargeFieldPlanning large{.half_width_m = 20.0};
//   OAIPP_ASSIGN_OR_RETURN(PlannedPath path,
//                          PlanInWindow(*planner, sparse_map, context, state, deadline, large));
#pragma once

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "core/mapping/dense_backend.h"
#include "core/mapping/field_window.h"
#include "core/mapping/sparse_gp_map.h"
#include "core/planning/planner.h"

namespace oaipp {

struct LargeFieldPlanning {
  // The window's half width around the UAV, metres: how far a plan's
  // waypoints and shots may reach. 20 m gives 41 x 41 cells at 1 m (E1's
  // field is 30 m wide), about 0.2 s to build at 90,000 cells
  // (docs/benchmarks.md). Valid: > 0, finite.
  double half_width_m = 20.0;
  FieldWindowOptions window = {};
  // For the window's dense inverse (the objective's is the planner's own).
  DenseBackend backend = {};
};

// The window of `map` around state.position_W and a plan on it by
// `planner`, with context's map replaced by the window. Errors as
// WindowAround, WindowMap and planner.Plan.
[[nodiscard]] absl::StatusOr<PlannedPath> PlanInWindow(Planner& planner, const SparseGpMap& map,
                                                       PlanningContext context,
                                                       const UavState& state, absl::Time deadline,
                                                       const LargeFieldPlanning& options);

}  // namespace oaipp
