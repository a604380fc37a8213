// What a picture draws of a mission's world on the ground, as plain rings
// and points in world metres (docs/method.md §1): filled from a mission by
// api/ (api/ground_outlines.h), drawn by render/ (render::Overlay), and
// sent by the live view.
#pragma once

#include <optional>
#include <vector>

#include "core/common/geometry.h"

namespace oaipp {

struct GroundOutlines {
  // Obstacles' footprints: closed polygons (vertices in order, >= 3 each;
  // the closing edge is implied), e.g. box corners or a cylinder as a
  // polygon.
  std::vector<std::vector<Vec2>> obstacle_footprints;
  // A search area's rings, outer rings and holes alike (closed, >= 3
  // vertices each).
  std::vector<std::vector<Vec2>> search_area_rings;
  // The fence the UAV stays inside (closed, >= 3 vertices).
  std::vector<std::vector<Vec2>> fence_rings;
  // No-fly zones' ground footprints (closed, >= 3 vertices).
  std::vector<std::vector<Vec2>> no_fly_footprints;
  // Where the UAV lands (MissionSpec.home), if it has one.
  std::optional<Vec2> home;
};

}  // namespace oaipp
