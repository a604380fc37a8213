#include "core/planning/large_field.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <span>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"

namespace oaipp {

Vec2 WindowCentre(const FieldGrid& field, const Eigen::VectorXd& added_precision,
                  double prior_variance, const Vec2& uav_W, const LargeFieldPlanning& options,
                  std::span<const std::uint8_t> area) {
  assert(added_precision.size() == field.num_cells());
  assert(area.empty() || area.size() == static_cast<std::size_t>(field.num_cells()));
  assert(prior_variance > 0.0);
  assert(options.lead_fraction >= 0.0 && options.lead_fraction < 1.0);
  if (options.lead_fraction == 0.0) return uav_W;
  const double side_m = options.half_width_m;
  const int side = std::max(1, static_cast<int>(std::lround(side_m / field.resolution_m())));
  const int bx = (field.nx() + side - 1) / side;
  const int by = (field.ny() + side - 1) / side;
  if (bx * by == 1) return uav_W;
  std::vector<double> uncertainty(static_cast<std::size_t>(bx) * by, 0.0);
  for (int r = 0; r < field.ny(); ++r) {
    for (int c = 0; c < field.nx(); ++c) {
      const int cell = field.Index(r, c);
      if (!area.empty() && area[static_cast<std::size_t>(cell)] == 0) continue;
      uncertainty[static_cast<std::size_t>(r / side) * bx + c / side] +=
          prior_variance / (1.0 + prior_variance * added_precision[cell]);
    }
  }
  // A square's centre: the middle of the cells it holds (those at the far
  // edges hold fewer).
  const auto middle = [&](int first, int n) {
    return 0.5 * (first + std::min(first + side, n)) * field.resolution_m();
  };
  double best_worth = -std::numeric_limits<double>::infinity();
  Vec2 best_W = uav_W;
  for (int q = 0; q < bx * by; ++q) {
    const Vec2 centre_W = field.min_W() + Vec2(middle((q % bx) * side, field.nx()),
                                               middle((q / bx) * side, field.ny()));
    const double worth = uncertainty[q] / ((centre_W - uav_W).norm() + side_m);
    if (worth > best_worth) {
      best_worth = worth;
      best_W = centre_W;
    }
  }
  const double distance = (best_W - uav_W).norm();
  if (distance <= side_m) return uav_W;
  return uav_W + (best_W - uav_W) * (options.lead_fraction * side_m / distance);
}

LargeFieldPlanning LargeFieldPlanning::ForField(const FieldGrid& field, bool lead,
                                                const DenseBackend& backend) {
  LargeFieldPlanning options{.half_width_m = kHalfWidthCells * field.resolution_m(),
                             .backend = backend};
  if (!lead) options.lead_fraction = 0.0;
  return options;
}

absl::StatusOr<FieldWindow> PlanningWindow(const FieldGrid& field,
                                           const Eigen::VectorXd* added_precision,
                                           double prior_variance, const Vec2& uav_W,
                                           const LargeFieldPlanning& options,
                                           std::span<const std::uint8_t> area) {
  if (!(options.lead_fraction >= 0.0 && options.lead_fraction < 1.0)) {
    return absl::InvalidArgumentError("options.lead_fraction: must lie in [0, 1)");
  }
  if (added_precision != nullptr && added_precision->size() != field.num_cells()) {
    return absl::InvalidArgumentError(absl::StrCat("added_precision: ", added_precision->size(),
                                                   " values for ", field.num_cells(), " cells"));
  }
  if (!area.empty() && area.size() != static_cast<std::size_t>(field.num_cells())) {
    return absl::InvalidArgumentError(
        absl::StrCat("search_area: ", area.size(), " cells for ", field.num_cells()));
  }
  Vec2 centre_W = uav_W;
  if (added_precision != nullptr) {
    centre_W = WindowCentre(field, *added_precision, prior_variance, uav_W, options, area);
  } else if (!area.empty()) {
    centre_W = WindowCentre(field, Eigen::VectorXd::Zero(field.num_cells()), prior_variance, uav_W,
                            options, area);
  }
  return WindowAround(field, centre_W, options.half_width_m);
}

std::vector<std::uint8_t> TransitArea(const FieldGrid& field, const FieldWindow& window,
                                      std::span<const std::uint8_t> area, const Vec2& uav_W,
                                      double reach_m) {
  assert(area.empty() || area.size() == static_cast<std::size_t>(field.num_cells()));
  assert(reach_m > 0.0);
  if (area.empty()) return {};
  for (const int cell : window.field_cells) {
    if (area[static_cast<std::size_t>(cell)] != 0) return {};
  }
  // The area cell nearest the UAV (the first in index order on a tie).
  double nearest = std::numeric_limits<double>::infinity();
  Vec2 goal_W = uav_W;
  for (int cell = 0; cell < field.num_cells(); ++cell) {
    if (area[static_cast<std::size_t>(cell)] == 0) continue;
    const Vec2 centre_W = field.CellCentreXY(cell);
    const double d = (centre_W - uav_W).squaredNorm();
    if (d < nearest) {
      nearest = d;
      goal_W = centre_W;
    }
  }
  if (!std::isfinite(nearest)) return {};
  // Its nearest point in the window's rectangle of cell centres.
  const double half = 0.5 * field.resolution_m();
  const Vec2 lo = window.grid.min_W() + Vec2::Constant(half);
  const Vec2 hi = window.grid.max_W() - Vec2::Constant(half);
  const Vec2 target_W = goal_W.cwiseMax(lo).cwiseMin(hi);
  std::vector<std::uint8_t> transit(static_cast<std::size_t>(field.num_cells()), 0);
  for (const int cell : window.field_cells) {
    if ((field.CellCentreXY(cell) - target_W).norm() <= reach_m) {
      transit[static_cast<std::size_t>(cell)] = 1;
    }
  }
  return transit;
}

absl::StatusOr<PlannedPath> PlanInWindow(Planner& planner, const SparseGpMap& map,
                                         PlanningContext context, const UavState& state,
                                         absl::Time deadline, const LargeFieldPlanning& options) {
  const bool added = (map.AddedPrecision().array() != 0.0).any();
  OAIPP_ASSIGN_OR_RETURN(FieldWindow window,
                         PlanningWindow(map.grid(), added ? &map.AddedPrecision() : nullptr,
                                        map.prior().fit.fitted_p0_variance,
                                        state.position_W.head<2>(), options, context.search_area));
  OAIPP_ASSIGN_OR_RETURN(GpMap local, WindowMap(map, window, options.window, options.backend));
  context.map = &local;
  // A search area lies over the field's cells: the planners then read the
  // field too (PlanningContext::search_area).
  if (!context.search_area.empty() && context.field == nullptr) context.field = &map.grid();
  // An area the window does not reach: look towards it instead (for the
  // planners that lead; the baselines choose over the whole field).
  const std::vector<std::uint8_t> transit =
      options.lead_fraction > 0.0
          ? TransitArea(map.grid(), window, context.search_area, state.position_W.head<2>(),
                        0.25 * options.half_width_m)
          : std::vector<std::uint8_t>{};
  if (!transit.empty()) context.search_area = transit;
  // A conditioned-covariance cache belongs to one map: not this window's.
  context.conditioned = nullptr;
  return planner.Plan(context, state, deadline);
}

}  // namespace oaipp
