// Always enough flight time to get home (docs/method.md §2.7).
//
// A mission with a home point keeps, at the end of every plan it returns, a
// way home: from where the plan ends, straight legs flown stop and go
// around obstacles, no-fly zones and the fence to the home point, then a
// vertical landing at the mission's landing speed. The plan is returned only
// if flying it, then the way home, then landing leaves at least the reserve
// of the budget; otherwise the plan is the way home itself, from the UAV's
// state now. Each plan's way home is checked with the same exact check as
// the plan, so the guarantee holds at every plan's end: the UAV can stop
// searching there and still land at home with the reserve unspent.
//
//   HomeConfig home{.home_W = {0, 0, 10}, .reserve_s = 20, .landing_speed_m_s = 1};
//   auto planner = std::make_unique<ReturnHomePlanner>(std::move(inner), common, home);
//   OAIPP_ASSIGN_OR_RETURN(PlannedPath path, planner->Plan(context, state, deadline));
//   // path.returning_home, or path.way_home and path.remaining_after_return_s >= 20
#pragma once

#include <algorithm>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/planning/path_scorer.h"
#include "core/planning/planner.h"

namespace oaipp {

// Where the UAV goes back to and how much flight time it keeps in hand
// (MissionSpec.home).
struct HomeConfig {
  // Where the way home ends, at rest, above the landing spot: inside the
  // flight volume.
  Vec3 home_W = Vec3::Zero();
  // Flight seconds left unspent when the UAV has landed; >= 0, finite.
  double reserve_s = 0.0;
  // Descent speed from home_W down to the ground (z = 0; the autopilot's
  // landing), m/s; > 0, finite.
  double landing_speed_m_s = 1.0;
  [[nodiscard]] absl::Status Validate() const;
  // Seconds the landing takes: home_W.z / landing_speed_m_s.
  [[nodiscard]] double LandingSeconds() const {
    return std::max(home_W.z(), 0.0) / landing_speed_m_s;
  }
};

// A way home and how it goes: the stop (when the UAV moved), then the
// corners of the route, ending at home.
struct WayHome {
  PolynomialTrajectory trajectory;
  std::vector<Vec3> route_W;  // from the first rest point to home, corners between
  double brake_s = 0.0;       // seconds braking to rest first (0 from rest)
};

// The way home from `state`: a brake to rest where the UAV moves
// (PlanBrake), then straight legs flown stop and go (PlanStopAndGo) along
// the shortest route around obstacles, zones and the fence (DetourAround)
// at the higher of the rest point's and home's heights, or, where no route
// exists there, by climbing to the top of the flight volume, crossing, and
// coming down over home. Every leg keeps the planner's obstacle clearance
// (PlannerLimits::ObstacleClearance) and the whole passes
// CheckTrajectoryExact. FailedPrecondition naming "home" when no such way
// exists (a braking problem says so as PlanBrake does).
[[nodiscard]] absl::StatusOr<WayHome> PlanWayHome(const Environment& environment,
                                                  const UavState& state, const Vec3& home_W,
                                                  const PlannerLimits& limits);

// Wraps a planner (MakePlanner does, outside StopFirstPlanner) so that
// every plan it returns leaves a way home within the budget, as the top of
// this file says. A plan of the inner planner is kept when
//   duration + way home from its end + landing <= remaining budget - reserve_s;
// then PlannedPath::way_home is that way home and remaining_after_return_s
// what is left after it and the landing. Otherwise the longest prefix of it
// that a bisection over eighths of its duration finds to meet the same rule,
// with the way home from where the prefix ends (braking first: the UAV moves
// there), is returned instead (stop_reason "cut_for_home"), so that the
// search goes on as long as the budget allows. Failing that, the returned
// path is the way home from `state` (returning_home true, stop_reason
// "way_home"),
// whose remaining_after_return_s may be below the reserve, or negative,
// when even going home at once does not fit: the UAV should still go.
// The inner planner's errors pass through unchanged; FailedPrecondition
// naming "home" when there is no way home at all.
class ReturnHomePlanner final : public WrappingPlanner {
 public:
  ReturnHomePlanner(std::unique_ptr<Planner> inner, PlannerCommon common, HomeConfig home)
      : WrappingPlanner(std::move(inner)), common_(std::move(common)), home_(home) {}

  [[nodiscard]] absl::StatusOr<PlannedPath> Plan(const PlanningContext& mission,
                                                 const UavState& state,
                                                 absl::Time deadline) override;

 private:
  // Prefixes tried: k / kCutSteps of the inner plan.
  static constexpr int kCutSteps = 8;
  // The inner plan `path` from `state` cut at a k / kCutSteps of its
  // duration where the way home from there (braking first) fits, the latest
  // a bisection over k finds, scored again (stop_reason "cut_for_home");
  // nullopt when none is found.
  [[nodiscard]] std::optional<PlannedPath> CutForHome(const PlanningContext& mission,
                                                      const UavState& state,
                                                      const PlannedPath& path) const;

  PlannerCommon common_;
  HomeConfig home_;
};

}  // namespace oaipp
