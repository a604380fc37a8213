// A dense window onto a large field's map, for the planner (docs/method.md
// §3.10).
//
// The planner's objectives need the covariance between the cells a candidate
// path sees. On a large field the map is a sparse precision Q (SparseGpMap)
// and its dense covariance is never formed; a plan, however, reaches only so
// far from the UAV. WindowMap gives the mean and the covariance of the cells
// of a square window W as a dense GpMap over a sub-grid, which every planner
// takes unchanged: its waypoints, footprints and objectives then live in the
// window.
//
// The mean is the map's exact posterior mean. The covariance is that of W
// conditioned on the lattice outside W' = W plus a margin of
// `margin_ranges` prior ranges on each side: by the Markov property that
// conditional has precision Q_W'W' exactly, and marginalising the margin M
// out of it leaves
//   P_WW ~ (Q_WW - Q_WM Q_MM^-1 Q_MW)^-1
// (Q_MM: a sparse Cholesky factor; Q_MW couples only the few rows of W
// within the stencil of M). Conditioning removes the uncertainty of what
// lies beyond W', so the variances come out slightly low near the window's
// edge. The error falls steeply with the margin (field_window_test.cc, on a
// 64 x 64 m field at 1 m: a covariance off by 0.36 of the prior variance
// with no margin, 3e-6 with one range, 1e-10 with two) and is zero when W'
// covers the whole lattice.
//
//   OAIPP_ASSIGN_OR_RETURN(FieldWindow window, WindowAround(map.grid(), uav.head<2>(), 20.0));
//   OAIPP_ASSIGN_OR_RETURN(GpMap local, WindowMap(map, window, {}, backend));
//   PlanningContext context{.environment = &env, .map = &local, ...};
#pragma once

#include <vector>

#include "absl/status/statusor.h"
#include "core/common/geometry.h"
#include "core/mapping/dense_backend.h"
#include "core/mapping/field_grid.h"
#include "core/mapping/gp_map.h"
#include "core/mapping/sparse_gp_map.h"

namespace oaipp {

// A rectangle of whole cells of a field.
struct FieldWindow {
  FieldGrid grid;     // the window's own grid (same resolution, cells aligned)
  int first_row = 0;  // its corner cell in the field
  int first_col = 0;
  std::vector<int> field_cells;  // field_cells[k]: the field cell of window cell k
};

// The cells of `field` within half_width_m of centre_W along x and along y
// (a cell counts when it overlaps that square), clipped to the field; a
// centre outside the field is first moved onto its nearest point, so the
// window is never empty. InvalidArgument naming the argument for a
// non-finite centre or a half width that is not positive and finite.
[[nodiscard]] absl::StatusOr<FieldWindow> WindowAround(const FieldGrid& field, const Vec2& centre_W,
                                                       double half_width_m);

struct FieldWindowOptions {
  // Lattice kept beyond the window on each side before the rest is
  // conditioned on, in prior ranges (GmrfFit::range_cells). Valid: >= 0,
  // finite.
  double margin_ranges = 1.0;
};

// The map over `window` (see above), with `backend` for the dense inverse.
// Errors: InvalidArgument for bad options or a window that is not one of
// map's field; ResourceExhausted when the window exceeds kMaxDenseCells;
// Internal when a factorisation fails.
[[nodiscard]] absl::StatusOr<GpMap> WindowMap(const SparseGpMap& map, const FieldWindow& window,
                                              const FieldWindowOptions& options,
                                              const DenseBackend& backend);

}  // namespace oaipp
