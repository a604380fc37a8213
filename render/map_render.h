// One picture of a field map for people: the mean (left panel) and the
// standard deviation (right panel) of the map, each coloured with viridis on
// [0, 1], with axes in metres, a colour bar and a title line, and optional
// overlays (obstacle footprints, target rectangles, paths, detections)
// drawn over both panels and named in a legend line below them. Plain
// shapes in, PNG bytes out: no protobuf, no gRPC, no OpenCV type in this
// header.
//
// Conventions (the same as the map itself, core/mapping/field_grid.h):
// cell (row, col) has index row * nx + col, the row running along world y
// and the column along world x, both from 0 at the (x_min, y_min) corner.
// North up: the top row of image pixels of a panel shows the grid's last row
// (largest y); x grows to the right. Each cell is an exact k x k block of
// pixels, k = kMaxCellPx, fewer for grids over 256 cells on a side so that a
// panel stays within about kMaxPanelPx pixels. Values outside [0, 1] are
// clipped and NaN is drawn as 0. The same inputs give the same bytes.
//
//   render::MapGrid grid{.nx = 40, .ny = 40, .resolution_m = 0.75,
//                        .x_min_m = -15, .y_min_m = -15};
//   render::MapLayers layers{.mean = mean, .std_dev = std_dev};
//   render::Overlay overlay;
//   overlay.path = flown_xy;
//   OAIPP_ASSIGN_OR_RETURN(std::string png,
//       render::RenderMapPng(grid, layers, overlay,
//                            {.mission = "missions/m-000001", .mission_time_s = 42.0,
//                             .trace = 123.45}));
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "core/common/geometry.h"
#include "core/common/ground_outlines.h"

namespace oaipp::render {

// Cells per side at most 8 px; panels at most about 2048 px per side.
inline constexpr int kMaxCellPx = 8;
inline constexpr int kMaxPanelPx = 2048;
// Grids wider or taller than this are refused (the image would be huge).
inline constexpr int kMaxCellsPerSide = 16384;

// The ground grid: nx x ny square cells of edge resolution_m metres, corner
// (x_min_m, y_min_m).
struct MapGrid {
  int nx = 0;
  int ny = 0;
  double resolution_m = 0.0;
  double x_min_m = 0.0;
  double y_min_m = 0.0;
};

// Per-cell values, nx * ny each, row-major as above. std_dev is the standard
// deviation (the square root of the variance), not the variance.
struct MapLayers {
  std::vector<double> mean;
  std::vector<double> std_dev;
};

// Drawn over both panels, clipped to the panel; all optional, world metres.
// Every coordinate must be finite. The world's outlines
// (core/common/ground_outlines.h) are drawn as: obstacles grey, the search
// area's rings white, the fence yellow, no-fly zones pink, home a white
// landing pad with a black H.
struct Overlay : GroundOutlines {
  Overlay() = default;
  // The world's outlines, nothing else yet.
  explicit Overlay(GroundOutlines ground) : GroundOutlines(std::move(ground)) {}
  // Ground rectangles (min corner, max corner). Green outlines.
  std::vector<std::pair<Vec2, Vec2>> targets;
  // A polyline, e.g. the flown path. Red, with a white dot at its start.
  std::vector<Vec2> path;
  // What the legend calls `path`.
  std::string path_label = "path";
  // A second polyline, e.g. the planned path. Magenta.
  std::vector<Vec2> planned_path;
  // A team's flown paths: the i-th in TeamColour(i), with a white dot at its
  // start, and its label in the legend.
  struct LabelledPath {
    std::string label;
    std::vector<Vec2> points;
  };
  std::vector<LabelledPath> team_paths;
  // Points, e.g. detections. Orange dots.
  std::vector<Vec2> detections;
};

// The title line, e.g. "missions/m-000001    t = 42.0 s    Tr(P) = 123.45".
// Empty / unset parts are left out; no title line when all are.
struct MapTitle {
  std::string mission;
  std::optional<double> mission_time_s;
  std::optional<double> trace;
};

// The colour of a team's i-th path, as 8-bit red, green, blue: eight colours
// that stand out on viridis and from each other, repeated past eight.
[[nodiscard]] std::array<std::uint8_t, 3> TeamColour(std::size_t i);

enum class Panel { kMean = 0, kStdDev = 1 };

// A rectangle of image pixels: columns [x, x + width), rows [y, y + height).
struct PixelRect {
  int x = 0;
  int y = 0;
  int width = 0;
  int height = 0;
};

// Where RenderMapPng puts things.
struct MapLayout {
  struct PanelLayout {
    PixelRect plot;        // the cells: nx * cell_px by ny * cell_px
    PixelRect colour_bar;  // value 1 at its top row, 0 at its bottom row
  };
  // Size of the whole image, pixels.
  int width = 0;
  int height = 0;
  // Edge of a cell's square block, pixels (k above).
  int cell_px = 0;
  // Indexed by Panel.
  std::array<PanelLayout, 2> panels;

  [[nodiscard]] const PanelLayout& panel(Panel p) const { return panels[static_cast<int>(p)]; }
};

// The layout of the image RenderMapPng(grid, layers, overlay, title) draws
// (it does not depend on the cell values). InvalidArgument as RenderMapPng
// for a bad grid or overlay.
[[nodiscard]] absl::StatusOr<MapLayout> ComputeMapLayout(const MapGrid& grid,
                                                         const Overlay& overlay = {},
                                                         const MapTitle& title = {});

// World point p_W (metres) -> continuous image coordinates (x right, y down)
// in `panel` of `layout`, where pixel (column c, row r) covers
// [c, c + 1) x [r, r + 1): the cell (row, col) centre lands in the middle of
// its block. Not clipped to the panel.
[[nodiscard]] Vec2 WorldToPixel(const MapGrid& grid, const MapLayout& layout, Panel panel,
                                const Vec2& p_W);

// The PNG. InvalidArgument naming the field for nx or ny not in
// [1, kMaxCellsPerSide], resolution_m not > 0 and finite, a non-finite
// corner, a layer whose size is not nx * ny ("mean: has 10 values, expected
// 1600"), a footprint with fewer than 3 vertices or a non-finite overlay
// coordinate. Internal when OpenCV fails.
[[nodiscard]] absl::StatusOr<std::string> RenderMapPng(const MapGrid& grid, const MapLayers& layers,
                                                       const Overlay& overlay = {},
                                                       const MapTitle& title = {});

}  // namespace oaipp::render
