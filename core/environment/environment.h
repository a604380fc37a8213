// The mission's known world: flight volume, obstacles and their ESDF, and
// the airspace closed to it (an inclusion fence, no-fly zones;
// core/environment/airspace.h) (docs/method.md §2).
//
// Environment keeps the obstacle set and the ESDF in step: every change is
// validated as a whole before anything is applied, and the ESDF is updated
// only in the region the change can affect. Exact queries (signed distance,
// segment clearance, line of sight) use the obstacle geometry; fast
// approximate ones use the ESDF. The clearance queries (signed distance,
// segment clearance, CloserThan, InCollision) count the closed airspace as
// obstacles count, always exactly (it is cheap: a polygon's edges and a few
// shapes); line of sight and the ESDF ignore it.
//
//   OAIPP_ASSIGN_OR_RETURN(Environment env, Environment::Create(volume, EsdfConfig{}));
//   OAIPP_RETURN_IF_ERROR(env.Apply({.add = {tower}}));
//   bool hit = env.InCollision(p_W, /*uav_radius_m=*/1.0);       // ESDF < r/2
//   bool free = env.IsSegmentClear(a_W, b_W, /*clearance_m=*/0.5);  // exact
//   bool seen = env.IsVisible(camera_W, ground_W);                     // occlusion
#pragma once

#include <map>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/common/geometry.h"
#include "core/environment/airspace.h"
#include "core/environment/esdf.h"
#include "core/environment/obstacle.h"

namespace oaipp {

// One atomic change of the obstacle set. Removed and replaced ids must
// exist, added ids must not, and an id may appear only once in a change.
struct ObstacleChange {
  std::vector<Obstacle> add = {};
  std::vector<std::string> remove = {};
  std::vector<Obstacle> replace = {};
};

class Environment final : public LineOfSight {
 public:
  // An empty world over `flight_volume`. Errors as Esdf::Create.
  [[nodiscard]] static absl::StatusOr<Environment> Create(const Aabb& flight_volume,
                                                          const EsdfConfig& esdf_config = {});

  Environment(Environment&&) = default;
  Environment& operator=(Environment&&) = default;
  Environment(const Environment&) = delete;
  Environment& operator=(const Environment&) = delete;
  [[nodiscard]] Environment Clone() const;

  // Applies `change` atomically. InvalidArgument for a malformed obstacle or
  // an id repeated within the change, AlreadyExists for adding an existing
  // id, NotFound for removing or replacing an unknown one. On error nothing
  // changes.
  [[nodiscard]] absl::Status Apply(const ObstacleChange& change);

  [[nodiscard]] const Aabb& flight_volume() const { return volume_; }
  [[nodiscard]] const std::map<std::string, Obstacle>& obstacles() const { return obstacles_; }
  [[nodiscard]] const Esdf& esdf() const { return esdf_; }
  // The closed airspace (none by default).
  [[nodiscard]] const Airspace& airspace() const { return airspace_; }
  void SetAirspace(Airspace airspace) { airspace_ = std::move(airspace); }
  // Shares the ESDF's values with an equal grid in `pool` (EsdfPool::Share);
  // true when it now shares another's.
  bool ShareEsdf(EsdfPool& pool) { return pool.Share(esdf_); }

  // Exact signed distance to the nearest obstacle or closed airspace,
  // metres; +infinity when the world is empty. Inside, the most negative of
  // their own signed distances (the exact union distance where they don't
  // overlap).
  [[nodiscard]] double SignedDistance(const Vec3& p_W) const;
  // As SignedDistance, the obstacles' alone (the airspace left out).
  [[nodiscard]] double ObstacleSignedDistance(const Vec3& p_W) const;
  // True when p_W lies strictly inside some obstacle (never for the
  // airspace: a zone covers no ground).
  [[nodiscard]] bool IsInsideObstacle(const Vec3& p_W) const {
    return ObstacleSignedDistance(p_W) < 0.0;
  }
  // Exact smallest signed distance from the segment to any obstacle.
  [[nodiscard]] double SegmentClearance(const Vec3& a_W, const Vec3& b_W) const;
  // True when every point of the segment is more than clearance_m from
  // every obstacle (exact).
  [[nodiscard]] bool IsSegmentClear(const Vec3& a_W, const Vec3& b_W, double clearance_m) const;
  // The paper's collision test (Eq. 2): ESDF(p) < r_uav / 2.
  [[nodiscard]] bool InCollision(const Vec3& p_W, double uav_radius_m) const {
    return CloserThan(p_W, 0.5 * uav_radius_m);
  }
  // By the ESDF: ESDF(p) < clearance_m (PlannerLimits::ObstacleClearance),
  // or (exactly) closer than that to the closed airspace.
  [[nodiscard]] bool CloserThan(const Vec3& p_W, double clearance_m) const {
    return esdf_.Distance(p_W) < clearance_m ||
           (!airspace_.empty() && airspace_.SignedDistance(p_W) < clearance_m);
  }
  // LineOfSight: true when the segment meets no obstacle's interior. A point
  // on the ground under a building is therefore never visible.
  [[nodiscard]] bool IsVisible(const Vec3& from_W, const Vec3& to_W) const override;
  // Which of `ground_points_W` are visible from camera_W.
  [[nodiscard]] std::vector<bool> VisibleFrom(const Vec3& camera_W,
                                              const std::vector<Vec3>& ground_points_W) const;

 private:
  Environment(const Aabb& volume, Esdf esdf) : volume_(volume), esdf_(std::move(esdf)) {}
  [[nodiscard]] std::vector<const Shape*> Shapes() const;

  Aabb volume_;
  std::map<std::string, Obstacle> obstacles_;  // ordered by id: deterministic iteration
  std::vector<Aabb> boxes_;                    // bounding boxes, same order as obstacles_
  Esdf esdf_;
  Airspace airspace_;
};

}  // namespace oaipp
