// Planning on a field too large for a dense map (docs/method.md §3.10): the
// planner runs unchanged on a dense window of the sparse map near the UAV
// (core/mapping/field_window.h), so its waypoints, footprints and
// objectives stay within the window. The window is centred on the UAV
// unless a square of the field farther off promises more uncertainty per
// metre of travel; then it leads towards that square (WindowCentre), so a
// search that has emptied its neighbourhood heads for what is left.
//
// The service plans through the same two steps (PlanningWindow, then the
// window's map), with the settings of LargeFieldPlanning::ForField.
//
//   const LargeFieldPlanning large = LargeFieldPlanning::ForField(grid, /*lead=*/true, {});
//   OAIPP_ASSIGN_OR_RETURN(PlannedPath path,
//                          PlanInWindow(*planner, sparse_map, context, state, deadline, large));
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "core/mapping/dense_backend.h"
#include "core/mapping/field_window.h"
#include "core/mapping/sparse_gp_map.h"
#include "core/planning/planner.h"

namespace oaipp {

struct LargeFieldPlanning {
  // The service's reach: this many cells each way (41 x 41 cells, about
  // 0.2 s to build at 90,000 cells, docs/benchmarks.md), whatever the
  // resolution.
  static constexpr int kHalfWidthCells = 20;
  // The window's half width around the UAV, metres: how far a plan's
  // waypoints and shots may reach. Valid: > 0, finite.
  double half_width_m = 20.0;
  // How far the window's centre may lead the UAV towards a more uncertain
  // square, as a fraction of half_width_m (WindowCentre). 0 keeps the window
  // centred on the UAV. Valid: [0, 1).
  double lead_fraction = 0.75;
  FieldWindowOptions window = {};
  // For the window's dense inverse (the objective's is the planner's own).
  DenseBackend backend = {};

  // What the service plans `field` with: kHalfWidthCells cells each way, a
  // lead when `lead` (OA-IPP; the baselines choose their destinations over
  // the whole field themselves, so their window stays on the UAV), the
  // window's inverse on `backend`.
  [[nodiscard]] static LargeFieldPlanning ForField(const FieldGrid& field, bool lead,
                                                   const DenseBackend& backend);
};

// Where the window of a plan from uav_W goes (docs/method.md §3.10,
// "Heading"). The field is cut into squares of half_width_m a side; each
// square's uncertainty is the sum over its cells of
//   v_c = p0 / (1 + p0 a_c),
// the variance cell c would have if the cells were independent (p0: the
// prior's variance, a_c: the precision its measurements added), and its
// worth that sum over (distance from uav_W to the square's centre +
// half_width_m). When the worthiest square (the first in row-major order on
// a tie) lies more than half_width_m from uav_W, the centre moves
// lead_fraction x half_width_m from uav_W towards it; otherwise it is uav_W.
// It reads only the measurements' additions, never a variance map, so it
// costs O(cells) and the same additions give the same centre. With a search
// area (`area`: one byte per field cell, nonzero inside; empty: all of
// it) only the cells inside count, so a UAV outside the area is led into it.
// Preconditions (asserted): added_precision has one entry per field cell,
// area none or one, p0 > 0, options valid.
[[nodiscard]] Vec2 WindowCentre(const FieldGrid& field, const Eigen::VectorXd& added_precision,
                                double prior_variance, const Vec2& uav_W,
                                const LargeFieldPlanning& options,
                                std::span<const std::uint8_t> area = {});

// The window a plan from uav_W reads: half_width_m each way around
// WindowCentre. With no measurement added yet (`added_precision` null) and
// no search area it is centred on the UAV: every square is then as
// uncertain as the prior, and leading anywhere would be arbitrary; with an
// area it leads towards the area's cells. InvalidArgument for a
// lead_fraction outside [0, 1), or additions or an area that do not fit the
// field; errors as WindowAround.
[[nodiscard]] absl::StatusOr<FieldWindow> PlanningWindow(const FieldGrid& field,
                                                         const Eigen::VectorXd* added_precision,
                                                         double prior_variance, const Vec2& uav_W,
                                                         const LargeFieldPlanning& options,
                                                         std::span<const std::uint8_t> area = {});

// A far search area's stand-in (docs/method.md §6.7, "Areas beyond the
// window"): when `window` holds none of the cells of `area` (a field mask,
// nonzero inside), the window's cells whose centres lie within reach_m of
// the window's point nearest to the area cell nearest uav_W, as a field
// mask; the objectives value only looking there, so the plan carries the
// UAV towards the area, and the next window holds more of it. Empty when
// there is no area, the window holds some of it, or the area has no cell.
// Preconditions (asserted): area empty or one byte per field cell,
// window one of field's, reach_m > 0.
[[nodiscard]] std::vector<std::uint8_t> TransitArea(const FieldGrid& field,
                                                    const FieldWindow& window,
                                                    std::span<const std::uint8_t> area,
                                                    const Vec2& uav_W, double reach_m);

// The window of `map` (PlanningWindow, the prior's fitted variance as p0,
// its additions unless it has none, context's search area) from
// state.position_W, and a plan on it by `planner`, with context's map
// replaced by the window (and, with a search area, its field set to the
// map's grid when unset, and, with a lead, the area replaced by
// TransitArea's, reach a quarter of the half width, when the window holds
// none of it). Errors as
// WindowAround, WindowMap and planner.Plan.
[[nodiscard]] absl::StatusOr<PlannedPath> PlanInWindow(Planner& planner, const SparseGpMap& map,
                                                       PlanningContext context,
                                                       const UavState& state, absl::Time deadline,
                                                       const LargeFieldPlanning& options);

}  // namespace oaipp
