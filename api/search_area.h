// Search areas: the ground a search team asks to be searched, as polygons
// with holes in the mission's world frame W (x east, y north, metres).
//
// A search area is a list of AreaPolygon: each an outer ring and zero or more
// holes (a pond, a fenced site). The ground searched is the union of the
// polygons: different polygons of the list may touch or overlap, and a hole
// of one polygon that another polygon covers is searched. Teams draw
// sectors one by one, often by hand, and neighbouring sectors that share a
// border overlap or leave slivers by round-off; refusing that would ask the
// client for exact polygon clipping this code does anyway. Within one
// polygon the rules are OGC's (a simple feature's polygon): every ring is
// simple, every hole lies inside its outer ring, holes do not overlap each
// other, and rings may touch only at single points that leave the inside
// in one piece.
//
// Validation, the cell mask and the area go through GEOS; this is the only
// place in api/ that uses it, and its types stay in the .cc file.
//
//   const std::vector<AreaPolygon> areas = {{.outer_m = {{0, 0}, {8, 0}, {8, 6}, {0, 6}},
//                                            .holes_m = {{{1, 1}, {3, 1}, {3, 3}, {1, 3}}}}};
//   OAIPP_RETURN_IF_ERROR(ValidateSearchArea(areas, "spec.search_areas"));
//   OAIPP_ASSIGN_OR_RETURN(std::vector<std::uint8_t> mask, SearchAreaMask(areas, grid));
//   OAIPP_ASSIGN_OR_RETURN(double area_m2, SearchAreaSize_m2(areas));  // 44
#pragma once

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/common/geometry.h"
#include "core/mapping/field_grid.h"

namespace oaipp::api {

// Vertices of one search area, all polygons and holes together: bounds the
// cost of a request before GEOS sees it, while a hand-drawn or imported
// sector rarely has more than a few hundred. Validation and the union are
// O(n log n): at the bound, one 10,000-vertex ring validated in 1-3 ms and a
// square with 2,499 square holes in 11 ms (measured as SearchAreaMask's
// times below).
inline constexpr int kMaxAreaVertices = 10'000;

// One polygon of a search area, metres in W. Rings are listed without
// repeating the first vertex (a repeated closing vertex is accepted and
// changes nothing), in either orientation.
struct AreaPolygon {
  std::vector<Vec2> outer_m = {};
  std::vector<std::vector<Vec2>> holes_m = {};
};

// A mission's search area: its polygons in W, and one byte per cell of the
// field in the grid's order (row * nx + col), 1 where the cell's centre
// lies in the area (SearchAreaMask).
struct SearchArea {
  std::vector<AreaPolygon> polygons;
  std::vector<std::uint8_t> mask;

  // Every ring, outer rings and holes alike, e.g. for a picture's outline.
  [[nodiscard]] std::vector<std::vector<Vec2>> Rings() const {
    std::vector<std::vector<Vec2>> rings;
    for (const AreaPolygon& polygon : polygons) {
      rings.push_back(polygon.outer_m);
      rings.insert(rings.end(), polygon.holes_m.begin(), polygon.holes_m.end());
    }
    return rings;
  }
};

// OK when `areas` is a search area this module accepts; an empty list is
// one (it searches nothing). Otherwise InvalidArgument whose message starts
// with the path of the offending part under `field` ("search_areas[1].outer",
// "search_areas[1].holes[0]") and says what is wrong where, quoting at most
// one location's coordinates, e.g.
//   search_areas[1].holes[0]: self-intersecting near (12.50, -3.00) m
// Refused: more than kMaxAreaVertices vertices in all (named `field`); a
// ring with fewer than 3 distinct vertices; a vertex that is not finite or
// lies beyond kMaxCoordinateM (api/limits.h) on an axis; a ring that crosses
// or touches itself; a hole that crosses, runs along, lies outside or cuts
// apart its outer ring; a hole that overlaps or lies inside another hole of its
// polygon (named at the later one). The status carries its field paths as
// data (core/common/field_error.h), so a caller can rename them.
[[nodiscard]] absl::Status ValidateSearchArea(std::span<const AreaPolygon> areas,
                                              std::string_view field);

// One byte per cell of `grid`, indexed as the grid is (row * nx + col): 1 when
// the cell's centre lies in the search area (inside some outer ring and in
// none of its holes, or inside another polygon of the list), else 0. The
// area is closed: a centre exactly on a ring counts as inside, as the
// grid's own region queries count it (core/mapping/field_grid.h). Cells off
// the area's bounding box are 0 without a test. Errors: as
// ValidateSearchArea with `field` "search_areas"; Internal when GEOS fails.
// One GEOS point and prepared test per cell: on a 500 x 500 grid (250,000
// cells, 1 m) a 64-vertex star with a 16-vertex hole over most of the field
// (145,148 cells inside) took 19 ms, a 10,000-vertex ring 28 ms, a square
// with 2,499 square holes (the vertex bound) 74 ms on 2 m cells (Release,
// GEOS 3.11, one core of the project's 2-core machine, best of 5 and 3 runs
// of a timing program kept out of the tree).
[[nodiscard]] absl::StatusOr<std::vector<std::uint8_t>> SearchAreaMask(
    std::span<const AreaPolygon> areas, const FieldGrid& grid);

// The ground area of the search area, m^2: the area of the union of the
// polygons (overlaps counted once, holes subtracted). Errors as
// SearchAreaMask.
[[nodiscard]] absl::StatusOr<double> SearchAreaSize_m2(std::span<const AreaPolygon> areas);

}  // namespace oaipp::api
