#include "core/environment/environment.h"

#include <limits>
#include <set>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"

namespace oaipp {
namespace {

void Grow(Aabb& box, bool& empty, const Aabb& other) {
  if (empty) {
    box = other;
    empty = false;
    return;
  }
  box.min_W = box.min_W.cwiseMin(other.min_W);
  box.max_W = box.max_W.cwiseMax(other.max_W);
}

}  // namespace

absl::StatusOr<Environment> Environment::Create(const Aabb& flight_volume,
                                                const EsdfConfig& esdf_config) {
  OAIPP_ASSIGN_OR_RETURN(Esdf esdf, Esdf::Create(flight_volume, esdf_config));
  return Environment(flight_volume, std::move(esdf));
}

Environment Environment::Clone() const {
  Environment copy(volume_, esdf_.Clone());
  copy.obstacles_ = obstacles_;
  copy.boxes_ = boxes_;
  copy.airspace_ = airspace_;
  return copy;
}

std::vector<const Shape*> Environment::Shapes() const {
  std::vector<const Shape*> shapes;
  shapes.reserve(obstacles_.size());
  for (const auto& [id, obstacle] : obstacles_) shapes.push_back(&obstacle.shape);
  return shapes;
}

absl::Status Environment::Apply(const ObstacleChange& change) {
  // Validate the whole change against the current state, then apply it.
  // An id may appear only once in a change, so the order of the parts
  // cannot matter.
  std::set<std::string> seen;
  auto once = [&](absl::string_view part, const std::string& id) -> absl::Status {
    if (seen.insert(id).second) return absl::OkStatus();
    return absl::InvalidArgumentError(
        absl::StrCat(part, ": id '", id, "' appears more than once in the change"));
  };
  for (const std::string& id : change.remove) {
    OAIPP_RETURN_IF_ERROR(once("remove", id));
    if (!obstacles_.contains(id)) {
      return absl::NotFoundError(absl::StrCat("remove: no obstacle with id '", id, "'"));
    }
  }
  for (const Obstacle& o : change.replace) {
    OAIPP_RETURN_IF_ERROR(ValidateObstacle(o));
    OAIPP_RETURN_IF_ERROR(once("replace", o.id));
    if (!obstacles_.contains(o.id)) {
      return absl::NotFoundError(absl::StrCat("replace: no obstacle with id '", o.id, "'"));
    }
  }
  for (const Obstacle& o : change.add) {
    OAIPP_RETURN_IF_ERROR(ValidateObstacle(o));
    OAIPP_RETURN_IF_ERROR(once("add", o.id));
    if (obstacles_.contains(o.id)) {
      return absl::AlreadyExistsError(absl::StrCat("add: obstacle id '", o.id, "' already exists"));
    }
  }

  // The ESDF's memory follows the obstacles' surroundings: bounded before
  // anything changes.
  std::vector<const Shape*> next;
  for (const auto& [id, obstacle] : obstacles_) {
    if (!seen.contains(id)) next.push_back(&obstacle.shape);
  }
  for (const Obstacle& o : change.replace) next.push_back(&o.shape);
  for (const Obstacle& o : change.add) next.push_back(&o.shape);
  if (const std::int64_t held = esdf_.HeldVoxelBound(next); held > esdf_.max_voxels()) {
    return absl::ResourceExhaustedError(
        absl::StrCat("obstacles: the distance field around them could need ", held,
                     " voxels, over the limit of ", esdf_.max_voxels(), "; use a larger voxel"));
  }

  Aabb changed;
  bool empty = true;
  for (const std::string& id : change.remove) {
    Grow(changed, empty, BoundingBox(obstacles_.at(id).shape));
    obstacles_.erase(id);
  }
  for (const Obstacle& o : change.replace) {
    Grow(changed, empty, BoundingBox(obstacles_.at(o.id).shape));
    Grow(changed, empty, BoundingBox(o.shape));
    obstacles_[o.id] = o;
  }
  for (const Obstacle& o : change.add) {
    Grow(changed, empty, BoundingBox(o.shape));
    obstacles_[o.id] = o;
  }
  boxes_.clear();
  for (const auto& [id, obstacle] : obstacles_) boxes_.push_back(BoundingBox(obstacle.shape));
  if (!empty) {
    const std::vector<const Shape*> shapes = Shapes();
    esdf_.Update(shapes, changed);
  }
  return absl::OkStatus();
}

double Environment::ObstacleSignedDistance(const Vec3& p_W) const {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& [id, obstacle] : obstacles_) {
    best = std::min(best, oaipp::SignedDistance(obstacle.shape, p_W));
  }
  return best;
}

double Environment::SignedDistance(const Vec3& p_W) const {
  return std::min(airspace_.SignedDistance(p_W), ObstacleSignedDistance(p_W));
}

double Environment::SegmentClearance(const Vec3& a_W, const Vec3& b_W) const {
  double best = airspace_.SegmentSignedDistance(a_W, b_W);
  const Aabb seg{a_W.cwiseMin(b_W), a_W.cwiseMax(b_W)};
  std::size_t i = 0;
  for (const auto& [id, obstacle] : obstacles_) {
    // The gap between bounding boxes bounds the distance from below.
    if (seg.Gap(boxes_[i++]) <= std::max(best, 0.0)) {
      best = std::min(best, SegmentSignedDistance(obstacle.shape, a_W, b_W));
    }
  }
  return best;
}

bool Environment::IsSegmentClear(const Vec3& a_W, const Vec3& b_W, double clearance_m) const {
  if (!airspace_.empty() && airspace_.SegmentSignedDistance(a_W, b_W) <= clearance_m) return false;
  const Aabb seg{a_W.cwiseMin(b_W), a_W.cwiseMax(b_W)};
  std::size_t i = 0;
  for (const auto& [id, obstacle] : obstacles_) {
    if (seg.Gap(boxes_[i++]) > clearance_m) continue;
    if (SegmentSignedDistance(obstacle.shape, a_W, b_W) <= clearance_m) return false;
  }
  return true;
}

bool Environment::IsVisible(const Vec3& from_W, const Vec3& to_W) const {
  const Aabb seg{from_W.cwiseMin(to_W), from_W.cwiseMax(to_W)};
  std::size_t i = 0;
  for (const auto& [id, obstacle] : obstacles_) {
    if (seg.Intersects(boxes_[i++]) && SegmentHits(obstacle.shape, from_W, to_W)) return false;
  }
  return true;
}

std::vector<bool> Environment::VisibleFrom(const Vec3& camera_W,
                                           const std::vector<Vec3>& ground_points_W) const {
  std::vector<bool> visible(ground_points_W.size());
  for (std::size_t i = 0; i < ground_points_W.size(); ++i) {
    visible[i] = IsVisible(camera_W, ground_points_W[i]);
  }
  return visible;
}

}  // namespace oaipp
