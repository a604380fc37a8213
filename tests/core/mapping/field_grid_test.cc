#include "core/mapping/field_grid.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/mapping/paper_grid.h"

namespace oaipp {
namespace {

using ::oaipp::testing::PaperGrid;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

TEST(FieldGridTest, PaperFieldIs40By40WithRowMajorNumbering) {
  const FieldGrid grid = PaperGrid();
  EXPECT_EQ(grid.nx(), 40);
  EXPECT_EQ(grid.ny(), 40);
  EXPECT_EQ(grid.num_cells(), 1600);
  EXPECT_TRUE(grid.max_W().isApprox(Vec2(15, 15)));
  // Cell 0 is the (x_min, y_min) corner; index = row * nx + col, row along y.
  EXPECT_TRUE(grid.CellCentre(0).isApprox(Vec3(-14.625, -14.625, 0)));
  EXPECT_TRUE(grid.CellCentre(1).isApprox(Vec3(-13.875, -14.625, 0)));
  EXPECT_TRUE(grid.CellCentre(40).isApprox(Vec3(-14.625, -13.875, 0)));
  EXPECT_EQ(grid.Index(3, 7), 127);
  EXPECT_EQ(grid.Row(127), 3);
  EXPECT_EQ(grid.Col(127), 7);
}

TEST(FieldGridTest, CellOfInvertsCellCentreAndHandlesEdges) {
  const FieldGrid grid = PaperGrid();
  for (int i = 0; i < grid.num_cells(); ++i) {
    ASSERT_EQ(grid.CellOf(grid.CellCentreXY(i)), i);
  }
  EXPECT_EQ(grid.CellOf(Vec2(-15, -15)), 0);
  EXPECT_EQ(grid.CellOf(Vec2(15, 15)), 1599);    // the far edges belong to the last cells
  EXPECT_EQ(grid.CellOf(Vec2(-14.25, -15)), 1);  // cells are half-open [lo, hi)
  EXPECT_EQ(grid.CellOf(Vec2(15.01, 0)), std::nullopt);
  EXPECT_EQ(grid.CellOf(Vec2(0, -15.01)), std::nullopt);
  EXPECT_EQ(grid.CellOf(Vec2(NAN, 0)), std::nullopt);
}

TEST(FieldGridTest, InvalidInputIsRefusedNamingTheField) {
  auto bad_res = FieldGrid::Create(Vec2(0, 0), 4, 4, 0.0);
  EXPECT_EQ(bad_res.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad_res.status().message(), HasSubstr("resolution_m"));
  auto bad_nx = FieldGrid::Create(Vec2(0, 0), 0, 4, 1.0);
  EXPECT_THAT(bad_nx.status().message(), HasSubstr("nx"));
  auto bad_origin = FieldGrid::Create(Vec2(INFINITY, 0), 4, 4, 1.0);
  EXPECT_THAT(bad_origin.status().message(), HasSubstr("origin_W.x"));
  auto too_big = FieldGrid::Create(Vec2(0, 0), 2001, 2000, 1.0);
  EXPECT_EQ(too_big.status().code(), absl::StatusCode::kResourceExhausted);
  auto not_whole = FieldGrid::FromBounds(Vec2(-15, -15), Vec2(15, 15), 0.7);
  EXPECT_EQ(not_whole.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(not_whole.status().message(), HasSubstr("whole number"));
  auto inverted = FieldGrid::FromBounds(Vec2(0, 5), Vec2(10, 5), 1.0);
  EXPECT_THAT(inverted.status().message(), HasSubstr("max_W.y"));
  auto huge = FieldGrid::FromBounds(Vec2(0, 0), Vec2(1e12, 1), 1.0);
  EXPECT_EQ(huge.status().code(), absl::StatusCode::kResourceExhausted);
}

// Brute-force twin: every cell, tested in the rectangle's own frame.
std::vector<int> BruteForceRectangle(const FieldGrid& grid, const Vec2& c, const Vec2& size,
                                     double yaw) {
  std::vector<int> cells;
  for (int i = 0; i < grid.num_cells(); ++i) {
    const Vec2 d = grid.CellCentreXY(i) - c;
    const double u = std::cos(yaw) * d.x() + std::sin(yaw) * d.y();
    const double v = -std::sin(yaw) * d.x() + std::cos(yaw) * d.y();
    if (std::abs(u) <= 0.5 * size.x() && std::abs(v) <= 0.5 * size.y()) cells.push_back(i);
  }
  return cells;
}

TEST(FieldGridTest, RotatedRectanglesMatchBruteForce) {
  const FieldGrid grid = PaperGrid();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pos(-20, 20), len(0, 25), yaw(-4, 4);
  for (int trial = 0; trial < 300; ++trial) {
    const Vec2 c{pos(rng), pos(rng)};
    const Vec2 size{len(rng), len(rng)};
    const double psi = trial % 3 == 0 ? 0.0 : yaw(rng);
    ASSERT_EQ(grid.CellsInRectangle(c, size, psi), BruteForceRectangle(grid, c, size, psi))
        << "trial " << trial;
    // The same rectangle as a polygon.
    const Vec2 ax(std::cos(psi), std::sin(psi)), ay(-std::sin(psi), std::cos(psi));
    const Vec2 hx = 0.5 * size.x() * ax, hy = 0.5 * size.y() * ay;
    const std::vector<Vec2> poly = {c - hx - hy, c + hx - hy, c + hx + hy, c - hx + hy};
    ASSERT_EQ(grid.CellsInPolygon(poly), BruteForceRectangle(grid, c, size, psi))
        << "trial " << trial;
  }
}

TEST(FieldGridTest, ConcavePolygonAndEdgesThroughCentres) {
  // 6 x 5 grid of 1 m cells from (0, 0); centres at x, y = 0.5, 1.5, ...
  // The L-shaped polygon below passes exactly through centres on its edges,
  // which count as inside:
  //   row 4  . . . . . .
  //   row 3  # # . . . .
  //   row 2  # # . . . .
  //   row 1  # # # # . .
  //   row 0  # # # # . .
  auto grid = FieldGrid::Create(Vec2(0, 0), 6, 5, 1.0);
  ASSERT_TRUE(grid.ok());
  const std::vector<Vec2> l_shape = {{0.5, 0.5}, {3.5, 0.5}, {3.5, 1.5},
                                     {1.5, 1.5}, {1.5, 3.5}, {0.5, 3.5}};
  EXPECT_THAT(grid->CellsInPolygon(l_shape), ElementsAre(0, 1, 2, 3, 6, 7, 8, 9, 12, 13, 18, 19));
  // Degenerate input gives no cells rather than an error.
  EXPECT_TRUE(grid->CellsInPolygon(std::vector<Vec2>{{0, 0}, {1, 1}}).empty());
  EXPECT_TRUE(grid->CellsInRectangle(Vec2(1, 1), Vec2(-1, 1)).empty());
}

// Separating-axis twin for a convex polygon against one cell square: they
// share positive area iff on every candidate axis (the square's two, each
// polygon edge's normal) the projections overlap by more than `gap` times
// the axis length.
bool ConvexOverlapsSquare(const std::vector<Vec2>& poly, const Vec2& lo, const Vec2& hi,
                          double gap) {
  const std::vector<Vec2> square = {lo, {hi.x(), lo.y()}, hi, {lo.x(), hi.y()}};
  std::vector<Vec2> axes = {{1, 0}, {0, 1}};
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const Vec2 e = poly[(i + 1) % poly.size()] - poly[i];
    axes.emplace_back(-e.y(), e.x());
  }
  for (const Vec2& a : axes) {
    const Vec2 unit = a.normalized();
    double p_lo = 1e300, p_hi = -1e300, s_lo = 1e300, s_hi = -1e300;
    for (const Vec2& v : poly) {
      p_lo = std::min(p_lo, unit.dot(v));
      p_hi = std::max(p_hi, unit.dot(v));
    }
    for (const Vec2& v : square) {
      s_lo = std::min(s_lo, unit.dot(v));
      s_hi = std::max(s_hi, unit.dot(v));
    }
    if (std::min(p_hi, s_hi) - std::max(p_lo, s_lo) <= gap) return false;
  }
  return true;
}

TEST(FieldGridTest, PolygonOverlapMatchesSeparatingAxesAndRectangleRule) {
  const FieldGrid grid = PaperGrid();
  const double r = grid.resolution_m();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> pos(-17, 17), len(0.05, 9), yaw(-4, 4);
  int ambiguous = 0, cells_seen = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Vec2 c{pos(rng), pos(rng)};
    const Vec2 size{len(rng), len(rng)};
    const double psi = trial % 3 == 0 ? 0.0 : yaw(rng);
    const Vec2 ax(std::cos(psi), std::sin(psi)), ay(-std::sin(psi), std::cos(psi));
    const Vec2 hx = 0.5 * size.x() * ax, hy = 0.5 * size.y() * ay;
    std::vector<Vec2> poly = {c - hx - hy, c + hx - hy, c + hx + hy, c - hx + hy};
    if (trial % 2 == 1) std::reverse(poly.begin(), poly.end());  // either orientation
    const std::vector<int> got = grid.CellsOverlappingPolygon(poly);
    ASSERT_TRUE(std::is_sorted(got.begin(), got.end()));
    if (psi == 0.0) {
      ASSERT_EQ(got, grid.CellsOverlapping(c - 0.5 * size, c + 0.5 * size)) << "trial " << trial;
    }
    for (int i = 0; i < grid.num_cells(); ++i) {
      const Vec2 lo = grid.CellCentreXY(i) - Vec2::Constant(0.5 * r);
      const Vec2 hi = lo + Vec2::Constant(r);
      // Overlapping by more than 1e-4 m on every axis (for a rectangle, more
      // than 1e-8 m^2), or apart by more than 1e-5 m: the rule must agree.
      const bool surely_in = ConvexOverlapsSquare(poly, lo, hi, 1e-4);
      const bool surely_out = !ConvexOverlapsSquare(poly, lo, hi, -1e-5);
      const bool in = std::binary_search(got.begin(), got.end(), i);
      if (surely_in) {
        ASSERT_TRUE(in) << "trial " << trial << " cell " << i;
      }
      if (surely_out) {
        ASSERT_FALSE(in) << "trial " << trial << " cell " << i;
      }
      ambiguous += !surely_in && !surely_out;
      cells_seen += in;
    }
  }
  EXPECT_GT(cells_seen, 3000);
  EXPECT_LT(ambiguous, 5);
}

TEST(FieldGridTest, PolygonOverlapConcaveTouchingAndDegenerate) {
  // 6 x 5 grid of 1 m cells from (0, 0). The L below covers rows 0-1 of
  // columns 0-3 fully and reaches 0.2 m into column 1 of rows 2-3 (beyond
  // x = 1): its inner corner must not claim cells (2, 2), (2, 3) whose
  // squares only its bounding box meets.
  //   row 3  # # . . . .
  //   row 2  # # . . . .
  //   row 1  # # # # . .
  //   row 0  # # # # . .
  auto grid = FieldGrid::Create(Vec2(0, 0), 6, 5, 1.0);
  ASSERT_TRUE(grid.ok());
  const std::vector<Vec2> l_shape = {{0, 0}, {4, 0}, {4, 2}, {1.2, 2}, {1.2, 4}, {0, 4}};
  EXPECT_THAT(grid->CellsOverlappingPolygon(l_shape),
              ElementsAre(0, 1, 2, 3, 6, 7, 8, 9, 12, 13, 18, 19));
  // Sharing only an edge or a corner with a cell is not overlapping it.
  const std::vector<Vec2> exact_cell = {{2, 1}, {3, 1}, {3, 2}, {2, 2}};
  EXPECT_THAT(grid->CellsOverlappingPolygon(exact_cell), ElementsAre(grid->Index(1, 2)));
  const std::vector<Vec2> diamond = {{3, 2}, {4, 3}, {3, 4}, {2, 3}};  // corners on cell edges
  EXPECT_THAT(
      grid->CellsOverlappingPolygon(diamond),
      ElementsAre(grid->Index(2, 2), grid->Index(2, 3), grid->Index(3, 2), grid->Index(3, 3)));
  // A thin triangle: its tip reaches 0.1 m into column 3.
  const std::vector<Vec2> triangle = {{0.5, 0.4}, {3.1, 0.5}, {0.5, 0.6}};
  EXPECT_THAT(grid->CellsOverlappingPolygon(triangle), ElementsAre(0, 1, 2, 3));
  EXPECT_TRUE(grid->CellsOverlappingPolygon(std::vector<Vec2>{{0, 0}, {1, 1}}).empty());
  EXPECT_TRUE(grid->CellsOverlappingPolygon(std::vector<Vec2>{{0, 0}, {1, 1}, {2, 2}}).empty());
  EXPECT_TRUE(grid->CellsOverlappingPolygon(std::vector<Vec2>{{0, 0}, {1, NAN}, {0, 1}}).empty());
  EXPECT_TRUE(
      grid->CellsOverlappingPolygon(std::vector<Vec2>{{-9, -9}, {-8, -9}, {-8, -8}}).empty());
}

// docs/reference-values.md: the 7 people of E1, each x in [px - 0.375, px + 0.375],
// y in [py, py + 2], cover 48 cells of the 40 x 40 grid (positive overlap).
TEST(FieldGridTest, E1PeopleCover48Cells) {
  const FieldGrid grid = PaperGrid();
  const double people[7][2] = {{8, -12}, {-6, -7},  {12, -7}, {-7, -12},
                               {4, -11}, {-12, -6}, {0, -7}};
  std::vector<int> all;
  for (const auto& p : people) {
    const std::vector<int> cells =
        grid.CellsOverlapping(Vec2(p[0] - 0.375, p[1]), Vec2(p[0] + 0.375, p[1] + 2));
    all.insert(all.end(), cells.begin(), cells.end());
  }
  std::sort(all.begin(), all.end());
  all.erase(std::unique(all.begin(), all.end()), all.end());
  EXPECT_EQ(all.size(), 48u);
  // Edges on cell edges do not claim the neighbour: exactly one cell.
  EXPECT_THAT(grid.CellsOverlapping(Vec2(0, 0), Vec2(0.75, 0.75)), ElementsAre(grid.Index(20, 20)));
  EXPECT_TRUE(grid.CellsOverlapping(Vec2(1, 1), Vec2(1, 2)).empty());
}

}  // namespace
}  // namespace oaipp
