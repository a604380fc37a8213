// Baseline planners for evaluation, also offered by the service
// (docs/method.md §8).
//
// Lawnmower: coverage at a fixed altitude (10 m in the paper). Lanes run
// along x, spaced by the camera footprint's y extent so that neighbouring
// footprints meet; obstacles taller than the altitude are flown around on
// the shortest route through the corners of their inflated footprints. The
// planner remembers where it is in its pattern across replans, and the
// pattern runs back and forth for as long as the mission lasts.
//
// Random: a destination drawn uniformly over the field and the flight
// altitudes, kept if the single-segment trajectory to it is collision-free.
//
//   LawnmowerPlanner mower(PlannerCommon{}, LawnmowerConfig{.altitude_m = 10});
//   RandomPlanner random(PlannerCommon{.seed = 3}, RandomConfig{});
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "core/planning/path_scorer.h"
#include "core/planning/planner.h"

namespace oaipp {

struct LawnmowerConfig {
  // Flight altitude, metres. Valid: > 0, inside the flight volume.
  double altitude_m = 10.0;
  // Pattern points flown per replan. Valid: >= 1.
  int points_per_plan = 2;
  // Extra clearance around obstacles on detours, beyond uav_radius_m / 2;
  // halved, then dropped, where a passage is too narrow for it.
  double detour_margin_m = 1.0;
  // Corner the pattern starts from: 0-3 fixed (bit 0: the highest-y lane
  // first, bit 1: each first lane flown from high x), or -1: drawn from
  // PlannerCommon::seed, so that a benchmark over seeds does not hinge on which side
  // of the field the targets lie. Valid: -1 .. 3.
  int start_corner = -1;
  [[nodiscard]] absl::Status Validate() const;
};

class LawnmowerPlanner final : public Planner {
 public:
  LawnmowerPlanner(PlannerCommon common, LawnmowerConfig config)
      : common_(std::move(common)), config_(std::move(config)) {}
  [[nodiscard]] absl::string_view name() const override { return "lawnmower"; }
  [[nodiscard]] absl::StatusOr<PlannedPath> Plan(const PlanningContext& mission,
                                                 const UavState& state,
                                                 absl::Time deadline) override;
  // The pattern's turning points for a field (exposed for tests). With a
  // search area (PlanningContext::search_area, over `grid`), each lane runs
  // only over the stretches where its band of the field (the lane's y
  // +- half the spacing) holds cells of the area, from half a footprint
  // inside each stretch's ends (its middle, for a stretch shorter than a
  // footprint); lanes with none are left out, and the UAV crosses the gaps
  // between stretches on the straight lane. Empty when the area holds no
  // cell.
  [[nodiscard]] static std::vector<Vec3> Pattern(const FieldGrid& grid, const Aabb& waypoint_box,
                                                 const DownwardCamera& camera, double altitude_m,
                                                 int corner = 0,
                                                 std::span<const std::uint8_t> area = {});
  // Index of the next pattern point to fly to (counts up for ever; the
  // pattern is flown back and forth).
  [[nodiscard]] int next_index() const { return next_index_; }
  // The next pattern index, in decimal.
  [[nodiscard]] std::string SaveState() const override;
  [[nodiscard]] absl::Status RestoreState(absl::string_view state) override;

 private:
  PlannerCommon common_;
  LawnmowerConfig config_;
  std::vector<Vec3> pattern_;
  int next_index_ = 0;
};

struct RandomConfig {
  // Destinations tried per replan before giving up. Valid: >= 1.
  int max_attempts = 200;
  [[nodiscard]] absl::Status Validate() const;
};

class RandomPlanner final : public Planner {
 public:
  RandomPlanner(PlannerCommon common, RandomConfig config)
      : common_(std::move(common)), config_(std::move(config)) {}
  [[nodiscard]] absl::string_view name() const override { return "random"; }
  [[nodiscard]] absl::StatusOr<PlannedPath> Plan(const PlanningContext& mission,
                                                 const UavState& state,
                                                 absl::Time deadline) override;

 private:
  PlannerCommon common_;
  RandomConfig config_;
};

// Shortest route at the height of `from` and `to` around obstacles and
// no-fly zones, through the corners of their footprints inflated by
// clearance_m and a polygon fence's corners moved inside by as much: the
// points to
// insert between `from` and `to` (empty when the straight segment is
// clear). NotFound when no route exists inside `box`.
[[nodiscard]] absl::StatusOr<std::vector<Vec3>> DetourAround(const Environment& environment,
                                                             const Vec3& from, const Vec3& to,
                                                             double clearance_m, const Aabb& box);

}  // namespace oaipp
