// The ground grid the field map lives on (docs/method.md §3).
//
// The field is an axis-aligned rectangle on the ground plane z = 0 of the
// world frame W, cut into nx x ny square cells of edge resolution_m. Cells are
// numbered row-major: index = row * nx + col, the row running along world y
// and the column along world x, both from 0 at the (x_min, y_min) corner. A
// cell's centre is origin + ((col + 0.5), (row + 0.5)) * resolution_m.
//
// Region queries ("which cells does this footprint cover?") go by cell
// centre: a cell belongs to a region when its centre lies inside the closed
// region (within a 1e-9 m tolerance, so that results do not flicker on
// round-off when a centre sits exactly on an edge). Results are sorted by
// index and hold no duplicates.
//
//   OAIPP_ASSIGN_OR_RETURN(FieldGrid grid,
//                          FieldGrid::FromBounds({-15, -15}, {15, 15}, /*resolution_m=*/0.75));
//   Vec3 c_W = grid.CellCentre(grid.Index(/*row=*/3, /*col=*/7));
//   std::optional<int> cell = grid.CellOf(Vec2(1.2, -4.0));
//   std::vector<int> under = grid.CellsInRectangle(Vec2(0, 0), Vec2(8.3, 11.5), /*yaw_rad=*/0);
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "core/common/geometry.h"

namespace oaipp {

class FieldGrid {
 public:
  // Largest grid: 2000 x 2000 cells (a square kilometre at 0.5 m). Which
  // map can hold a grid is the map's limit (GpMap: kMaxDenseCells; the
  // sparse map: its memory estimate).
  static constexpr std::int64_t kMaxCells = 4'000'000;

  // The grid with corner origin_W = (x_min, y_min), metres, nx cells along x
  // and ny along y. InvalidArgument (naming the field) unless origin_W is
  // finite, resolution_m > 0 and finite, nx, ny >= 1 and the far corner is
  // finite; ResourceExhausted when nx * ny > kMaxCells.
  [[nodiscard]] static absl::StatusOr<FieldGrid> Create(const Vec2& origin_W, int nx, int ny,
                                                        double resolution_m);

  // The grid covering [min_W, max_W] exactly. The extent along each axis must
  // be a whole number of cells (to 1e-6 relative): a field of 30 m at
  // 0.75 m gives 40 cells, one of 30 m at 0.7 m is refused. Errors as Create,
  // and InvalidArgument when max_W <= min_W or the extent is not a whole
  // number of cells.
  [[nodiscard]] static absl::StatusOr<FieldGrid> FromBounds(const Vec2& min_W, const Vec2& max_W,
                                                            double resolution_m);

  [[nodiscard]] int nx() const { return nx_; }
  [[nodiscard]] int ny() const { return ny_; }
  [[nodiscard]] int num_cells() const { return nx_ * ny_; }
  [[nodiscard]] double resolution_m() const { return resolution_m_; }
  // Corners of the field, metres.
  [[nodiscard]] const Vec2& min_W() const { return origin_W_; }
  [[nodiscard]] Vec2 max_W() const {
    return origin_W_ + resolution_m_ * Vec2(static_cast<double>(nx_), static_cast<double>(ny_));
  }

  [[nodiscard]] bool IsValidCell(int index) const { return index >= 0 && index < num_cells(); }
  // Row-major numbering. Preconditions: 0 <= row < ny, 0 <= col < nx, resp.
  // IsValidCell(index).
  [[nodiscard]] int Index(int row, int col) const { return row * nx_ + col; }
  [[nodiscard]] int Row(int index) const { return index / nx_; }
  [[nodiscard]] int Col(int index) const { return index % nx_; }

  // Centre of a cell on the ground (z = 0), metres. Precondition:
  // IsValidCell(index).
  [[nodiscard]] Vec2 CellCentreXY(int index) const;
  [[nodiscard]] Vec3 CellCentre(int index) const;

  // The cell holding p_W (x, y; metres): cells are half-open [lo, hi) except
  // that the field's far edges belong to the last row and column. nullopt
  // outside the field or for a non-finite point.
  [[nodiscard]] std::optional<int> CellOf(const Vec2& p_W) const;

  // Cells whose centre lies in the rectangle with centre centre_W, edge
  // lengths size_m (along its own x, y axes) and yaw yaw_rad (its x axis
  // rotated by yaw from world x, counter-clockwise seen from above).
  // Non-finite input or a negative size gives no cells.
  [[nodiscard]] std::vector<int> CellsInRectangle(const Vec2& centre_W, const Vec2& size_m,
                                                  double yaw_rad = 0.0) const;

  // Cells whose centre lies in the simple polygon `polygon_W` (vertices in
  // order, either orientation; the closing edge is implied). Fewer than three
  // vertices or a non-finite vertex gives no cells.
  [[nodiscard]] std::vector<int> CellsInPolygon(std::span<const Vec2> polygon_W) const;

  // Cells whose square overlaps the axis-aligned rectangle [min_W, max_W]
  // with positive area (for rasterising ground-truth targets, whose edges
  // often lie on cell edges). Empty when max_W <= min_W on either axis.
  [[nodiscard]] std::vector<int> CellsOverlapping(const Vec2& min_W, const Vec2& max_W) const;

  // Cells whose ground lies under an obstacle: the point 1 mm above the
  // cell centre is inside one (`inside_obstacle`). Such ground cannot hold
  // targets (docs/method.md §3.7); the map fuses it once as near-certain
  // zeros. Sorted.
  [[nodiscard]] std::vector<int> CellsUnderObstacles(
      const std::function<bool(const Vec3& p_W)>& inside_obstacle) const;

  // Cells whose square overlaps the simple polygon `polygon_W` (vertices in
  // order, either orientation) with positive area: the rule above for any
  // polygon, e.g. a detection box's ground polygon, so that a detection of a
  // target marks the cells its ground truth marks. Overlaps of at most
  // min_area_m2 count as touching, not overlapping: they are round-off of
  // edges that coincide (a 1e-12 m sliver along a 1 m edge is 1e-12 m^2),
  // while a corner reaching 1e-4 m into a cell covers at least 1e-8 m^2.
  // Sorted. Fewer than three vertices or a non-finite vertex gives no cells.
  [[nodiscard]] std::vector<int> CellsOverlappingPolygon(std::span<const Vec2> polygon_W,
                                                         double min_area_m2 = 1e-10) const;

 private:
  FieldGrid(const Vec2& origin_W, int nx, int ny, double resolution_m)
      : origin_W_(origin_W), nx_(nx), ny_(ny), resolution_m_(resolution_m) {}

  // Cells whose centre lies in the axis-aligned box [lo_W, hi_W] and passes
  // `inside`; the box only bounds the search.
  template <typename Inside>
  std::vector<int> CellsInBox(const Vec2& lo_W, const Vec2& hi_W, Inside inside) const;

  Vec2 origin_W_;
  int nx_;
  int ny_;
  double resolution_m_;
};

}  // namespace oaipp
