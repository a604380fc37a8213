#include "render/map_checks.h"

#include <cmath>
#include <cstddef>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "core/common/geometry.h"

namespace oaipp::render {
namespace {

absl::Status CheckPoint(absl::string_view field, std::size_t i, const Vec2& p) {
  if (AllFinite(p)) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(field, "[", i, "]: must be finite, got (", p.x(), ", ", p.y(), ")"));
}

// Closed polygons named `name`: at least 3 finite vertices each.
absl::Status CheckPolygons(absl::string_view name, const std::vector<std::vector<Vec2>>& polygons) {
  for (std::size_t i = 0; i < polygons.size(); ++i) {
    const std::vector<Vec2>& polygon = polygons[i];
    if (polygon.size() < 3) {
      return absl::InvalidArgumentError(
          absl::StrCat(name, "[", i, "]: has ", polygon.size(), " vertices, needs at least 3"));
    }
    for (std::size_t j = 0; j < polygon.size(); ++j) {
      if (absl::Status s = CheckPoint(absl::StrCat(name, "[", i, "]"), j, polygon[j]); !s.ok()) {
        return s;
      }
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status ValidateGrid(const MapGrid& grid) {
  const std::pair<const char*, int> sides[] = {{"nx", grid.nx}, {"ny", grid.ny}};
  for (const auto& [name, n] : sides) {
    if (n < 1 || n > kMaxCellsPerSide) {
      return absl::InvalidArgumentError(
          absl::StrCat(name, ": must be in [1, ", kMaxCellsPerSide, "], got ", n));
    }
  }
  if (absl::Status s = CheckPositive("resolution_m", grid.resolution_m); !s.ok()) return s;
  if (absl::Status s = CheckFinite("x_min_m", grid.x_min_m); !s.ok()) return s;
  if (absl::Status s = CheckFinite("y_min_m", grid.y_min_m); !s.ok()) return s;
  if (!std::isfinite(grid.x_min_m + grid.nx * grid.resolution_m) ||
      !std::isfinite(grid.y_min_m + grid.ny * grid.resolution_m)) {
    return absl::InvalidArgumentError("resolution_m: the far corner of the grid is not finite");
  }
  return absl::OkStatus();
}

absl::Status ValidateOverlay(const Overlay& overlay) {
  if (absl::Status s = CheckPolygons("overlay.obstacle_footprints", overlay.obstacle_footprints);
      !s.ok()) {
    return s;
  }
  if (absl::Status s = CheckPolygons("overlay.search_area_rings", overlay.search_area_rings);
      !s.ok()) {
    return s;
  }
  if (absl::Status s = CheckPolygons("overlay.fence_rings", overlay.fence_rings); !s.ok()) {
    return s;
  }
  if (absl::Status s = CheckPolygons("overlay.no_fly_footprints", overlay.no_fly_footprints);
      !s.ok()) {
    return s;
  }
  for (std::size_t i = 0; i < overlay.targets.size(); ++i) {
    if (absl::Status s = CheckPoint("overlay.targets(min)", i, overlay.targets[i].first); !s.ok())
      return s;
    if (absl::Status s = CheckPoint("overlay.targets(max)", i, overlay.targets[i].second); !s.ok())
      return s;
  }
  const std::pair<const char*, const std::vector<Vec2>*> lists[] = {
      {"overlay.path", &overlay.path},
      {"overlay.planned_path", &overlay.planned_path},
      {"overlay.detections", &overlay.detections}};
  for (const auto& [name, points] : lists) {
    for (std::size_t i = 0; i < points->size(); ++i) {
      if (absl::Status s = CheckPoint(name, i, (*points)[i]); !s.ok()) return s;
    }
  }
  if (overlay.home.has_value()) {
    if (absl::Status s = CheckPoint("overlay.home", 0, *overlay.home); !s.ok()) return s;
  }
  for (std::size_t p = 0; p < overlay.team_paths.size(); ++p) {
    const std::vector<Vec2>& points = overlay.team_paths[p].points;
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (absl::Status s = CheckPoint(absl::StrCat("overlay.team_paths[", p, "]"), i, points[i]);
          !s.ok()) {
        return s;
      }
    }
  }
  return absl::OkStatus();
}

absl::Status ValidateLayers(const MapGrid& grid, const MapLayers& layers) {
  const auto expected = static_cast<std::size_t>(grid.nx) * static_cast<std::size_t>(grid.ny);
  const std::pair<const char*, const std::vector<double>*> fields[] = {
      {"mean", &layers.mean}, {"std_dev", &layers.std_dev}};
  for (const auto& [name, values] : fields) {
    if (values->size() != expected) {
      return absl::InvalidArgumentError(
          absl::StrCat(name, ": has ", values->size(), " values, expected ", expected));
    }
  }
  return absl::OkStatus();
}

}  // namespace oaipp::render
