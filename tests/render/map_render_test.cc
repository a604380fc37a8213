#include "render/map_render.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "opencv2/core.hpp"
#include "opencv2/imgcodecs.hpp"
#include "opencv2/imgproc.hpp"

namespace oaipp::render {
namespace {

using ::testing::HasSubstr;

// The test field: 40 x 40 cells of 0.75 m over [-15, 15]^2.
constexpr int kN = 40;
constexpr double kRes = 0.75;
constexpr double kMin = -15.0;
const MapGrid kGrid{kN, kN, kRes, kMin, kMin};

MapLayers Flat(double mean, double std_dev, const MapGrid& grid = kGrid) {
  const std::size_t n = static_cast<std::size_t>(grid.nx) * grid.ny;
  return {std::vector<double>(n, mean), std::vector<double>(n, std_dev)};
}

cv::Mat Decode(const std::string& png) {
  const std::vector<std::uint8_t> bytes(png.begin(), png.end());
  return cv::imdecode(bytes, cv::IMREAD_COLOR);
}

// OpenCV's viridis colour (BGR) for a grey level, worked out here on its own.
cv::Vec3b Viridis(int level) {
  cv::Mat grey(1, 1, CV_8UC1, cv::Scalar(level));
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_VIRIDIS);
  return colour.at<cv::Vec3b>(0, 0);
}

cv::Vec3b At(const cv::Mat& image, int x, int y) { return image.at<cv::Vec3b>(y, x); }

// The pixel (column, row) holding a continuous image point.
cv::Point PixelOf(const Vec2& p) {
  return {static_cast<int>(std::floor(p.x())), static_cast<int>(std::floor(p.y()))};
}

// True when a pixel within `radius` of `centre` satisfies `pred`.
template <typename Pred>
bool AnyNear(const cv::Mat& image, cv::Point centre, int radius, Pred pred) {
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      if (pred(At(image, centre.x + dx, centre.y + dy))) return true;
    }
  }
  return false;
}

bool IsRed(const cv::Vec3b& bgr) { return bgr[2] >= 200 && bgr[1] <= 60 && bgr[0] <= 60; }
bool IsGreen(const cv::Vec3b& bgr) { return bgr[1] >= 180 && bgr[2] <= 40 && bgr[0] <= 40; }
bool IsWhite(const cv::Vec3b& bgr) { return bgr[0] >= 230 && bgr[1] >= 230 && bgr[2] >= 230; }
bool IsDark(const cv::Vec3b& bgr) { return bgr[0] < 100 && bgr[1] < 100 && bgr[2] < 100; }

// The rectangle [x0, x1] x [y0, y1] as a closed ring.
std::vector<Vec2> Square(double x0, double y0, double x1, double y1) {
  return {Vec2(x0, y0), Vec2(x1, y0), Vec2(x1, y1), Vec2(x0, y1)};
}

int DarkPixels(const cv::Mat& image, const cv::Rect& area) {
  int n = 0;
  for (int y = area.y; y < area.y + area.height; ++y) {
    for (int x = area.x; x < area.x + area.width; ++x) n += IsDark(At(image, x, y)) ? 1 : 0;
  }
  return n;
}

MapLayout LayoutOrDie(const MapGrid& grid, const Overlay& overlay = {},
                      const MapTitle& title = {}) {
  absl::StatusOr<MapLayout> layout = ComputeMapLayout(grid, overlay, title);
  EXPECT_TRUE(layout.ok()) << layout.status();
  return layout.ok() ? *layout : MapLayout{};
}

cv::Mat RenderOrDie(const MapGrid& grid, const MapLayers& layers, const Overlay& overlay = {},
                    const MapTitle& title = {}) {
  absl::StatusOr<std::string> png = RenderMapPng(grid, layers, overlay, title);
  EXPECT_TRUE(png.ok()) << png.status();
  if (!png.ok()) return {};
  cv::Mat image = Decode(*png);
  EXPECT_FALSE(image.empty());
  return image;
}

TEST(MapRenderTest, ImageSizeIsTheLayoutsAndCellsAreEightPixels) {
  const MapTitle title{"missions/m-000001", 42.0, 123.45};
  const MapLayout layout = LayoutOrDie(kGrid, {}, title);
  const cv::Mat image = RenderOrDie(kGrid, Flat(0.5, 0.5), {}, title);
  EXPECT_EQ(image.cols, layout.width);
  EXPECT_EQ(image.rows, layout.height);
  EXPECT_EQ(layout.cell_px, 8);
  for (const Panel p : {Panel::kMean, Panel::kStdDev}) {
    const PixelRect& plot = layout.panel(p).plot;
    const PixelRect& bar = layout.panel(p).colour_bar;
    EXPECT_EQ(plot.width, 40 * 8);
    EXPECT_EQ(plot.height, 40 * 8);
    EXPECT_EQ(bar.y, plot.y);
    EXPECT_GE(bar.height, plot.height);
    EXPECT_GT(bar.x, plot.x + plot.width);  // colour bar right of the plot
    // Room for the frame (1 px) and labels on every side.
    EXPECT_GT(plot.x, 1);
    EXPECT_GT(plot.y, 1);
    EXPECT_LT(plot.y + plot.height + 1, layout.height);
    EXPECT_LT(bar.x + bar.width + 1, layout.width);
  }
  // Mean on the left, standard deviation on the right.
  EXPECT_GT(layout.panel(Panel::kStdDev).plot.x,
            layout.panel(Panel::kMean).colour_bar.x + layout.panel(Panel::kMean).colour_bar.width);
}

TEST(MapRenderTest, LargeGridsGetSmallerCells) {
  const MapGrid grid{300, 200, 0.1, 0.0, 0.0};
  const MapLayout layout = LayoutOrDie(grid);
  EXPECT_EQ(layout.cell_px, 2048 / 300);  // 6
  EXPECT_EQ(layout.panel(Panel::kMean).plot.width, 300 * 6);
  EXPECT_EQ(layout.panel(Panel::kMean).plot.height, 200 * 6);
  const cv::Mat image = RenderOrDie(grid, Flat(0.3, 0.7, grid));
  EXPECT_EQ(image.cols, layout.width);
  EXPECT_EQ(image.rows, layout.height);
}

TEST(MapRenderTest, WorldToPixelMapsTheFieldCornersToThePlotCorners) {
  const MapLayout layout = LayoutOrDie(kGrid);
  for (const Panel p : {Panel::kMean, Panel::kStdDev}) {
    const PixelRect& plot = layout.panel(p).plot;
    // North-west corner (x_min, y_max) is the plot's top-left.
    const Vec2 nw = WorldToPixel(kGrid, layout, p, Vec2(-15.0, 15.0));
    EXPECT_DOUBLE_EQ(nw.x(), plot.x);
    EXPECT_DOUBLE_EQ(nw.y(), plot.y);
    // South-east corner (x_max, y_min) is its bottom-right.
    const Vec2 se = WorldToPixel(kGrid, layout, p, Vec2(15.0, -15.0));
    EXPECT_DOUBLE_EQ(se.x(), plot.x + 320);
    EXPECT_DOUBLE_EQ(se.y(), plot.y + 320);
  }
}

TEST(MapRenderTest, ACellOfMeanOneIsViridisTopAtItsMetres) {
  constexpr int kRow = 5, kCol = 30;
  MapLayers layers = Flat(0.25, 0.0);
  layers.mean[kRow * kN + kCol] = 1.0;
  const MapLayout layout = LayoutOrDie(kGrid);
  const cv::Mat image = RenderOrDie(kGrid, layers);
  const PixelRect& plot = layout.panel(Panel::kMean).plot;

  // The cell's block, by hand: column 30 from the left, row 5 from the
  // bottom (north up), 8 px each.
  const int x0 = plot.x + kCol * 8;
  const int y0 = plot.y + (kN - 1 - kRow) * 8;
  // The same place from the cell centre's metres.
  const Vec2 centre_W(kMin + (kCol + 0.5) * kRes, kMin + (kRow + 0.5) * kRes);
  const cv::Point centre_px = PixelOf(WorldToPixel(kGrid, layout, Panel::kMean, centre_W));
  EXPECT_EQ(centre_px, cv::Point(x0 + 4, y0 + 4));

  for (int dy = 0; dy < 8; ++dy) {
    for (int dx = 0; dx < 8; ++dx) {
      ASSERT_EQ(At(image, x0 + dx, y0 + dy), Viridis(255)) << dx << "," << dy;
    }
  }
  // Just outside the block: the background, viridis(round(0.25 * 255)).
  EXPECT_EQ(At(image, x0 - 1, y0 + 4), Viridis(64));
  EXPECT_EQ(At(image, x0 + 8, y0 + 4), Viridis(64));
  EXPECT_EQ(At(image, x0 + 4, y0 - 1), Viridis(64));
  EXPECT_EQ(At(image, x0 + 4, y0 + 8), Viridis(64));
  // The standard deviation panel is all 0 there.
  const Vec2 in_std = WorldToPixel(kGrid, layout, Panel::kStdDev, centre_W);
  EXPECT_EQ(At(image, PixelOf(in_std).x, PixelOf(in_std).y), Viridis(0));
}

TEST(MapRenderTest, AStdDevOfOneShowsInTheRightPanel) {
  MapLayers layers = Flat(0.0, 0.5);
  layers.std_dev[12 * kN + 7] = 1.0;
  const MapLayout layout = LayoutOrDie(kGrid);
  const cv::Mat image = RenderOrDie(kGrid, layers);
  const Vec2 centre_W(kMin + 7.5 * kRes, kMin + 12.5 * kRes);
  const cv::Point in_std = PixelOf(WorldToPixel(kGrid, layout, Panel::kStdDev, centre_W));
  const cv::Point in_mean = PixelOf(WorldToPixel(kGrid, layout, Panel::kMean, centre_W));
  EXPECT_EQ(At(image, in_std.x, in_std.y), Viridis(255));
  EXPECT_EQ(At(image, in_std.x + 8, in_std.y), Viridis(128));  // round(0.5 * 255)
  EXPECT_EQ(At(image, in_mean.x, in_mean.y), Viridis(0));
}

TEST(MapRenderTest, NorthIsUp) {
  // Only the grid's last row (the largest y) is 1.
  MapLayers layers = Flat(0.0, 0.0);
  for (int col = 0; col < kN; ++col) layers.mean[(kN - 1) * kN + col] = 1.0;
  const MapLayout layout = LayoutOrDie(kGrid);
  const cv::Mat image = RenderOrDie(kGrid, layers);
  const PixelRect& plot = layout.panel(Panel::kMean).plot;
  for (int y = plot.y; y < plot.y + plot.height; ++y) {
    const bool top_cells = y < plot.y + 8;
    ASSERT_EQ(At(image, plot.x + plot.width / 2, y), top_cells ? Viridis(255) : Viridis(0))
        << "row " << y - plot.y << " of the plot";
  }
}

TEST(MapRenderTest, ValuesAreClippedAndNanIsZero) {
  MapLayers layers = Flat(0.0, 0.0);
  layers.mean[0] = 2.0;                                       // row 0, col 0
  layers.mean[1] = -1.0;                                      // row 0, col 1
  layers.mean[2] = std::numeric_limits<double>::quiet_NaN();  // row 0, col 2
  layers.mean[3] = std::numeric_limits<double>::infinity();   // row 0, col 3
  const MapLayout layout = LayoutOrDie(kGrid);
  const cv::Mat image = RenderOrDie(kGrid, layers);
  const PixelRect& plot = layout.panel(Panel::kMean).plot;
  const int y = plot.y + plot.height - 4;  // middle of the bottom row of cells
  EXPECT_EQ(At(image, plot.x + 4, y), Viridis(255));
  EXPECT_EQ(At(image, plot.x + 12, y), Viridis(0));
  EXPECT_EQ(At(image, plot.x + 20, y), Viridis(0));
  EXPECT_EQ(At(image, plot.x + 28, y), Viridis(255));
}

TEST(MapRenderTest, ColourBarRunsFromViridisZeroAtTheBottomToTopAtTheTop) {
  const MapLayout layout = LayoutOrDie(kGrid);
  const cv::Mat image = RenderOrDie(kGrid, Flat(0.5, 0.5));
  for (const Panel p : {Panel::kMean, Panel::kStdDev}) {
    const PixelRect& bar = layout.panel(p).colour_bar;
    const int x = bar.x + bar.width / 2;
    EXPECT_EQ(At(image, x, bar.y), Viridis(255));
    EXPECT_EQ(At(image, x, bar.y + bar.height - 1), Viridis(0));
    EXPECT_EQ(At(image, bar.x, bar.y), At(image, bar.x + bar.width - 1, bar.y));
    // Halfway up: about viridis(128).
    const cv::Vec3b middle = At(image, x, bar.y + (bar.height - 1) / 2);
    EXPECT_TRUE(middle == Viridis(127) || middle == Viridis(128) || middle == Viridis(129));
  }
}

TEST(MapRenderTest, AxesAndColourBarsHaveLabels) {
  const MapLayout layout = LayoutOrDie(kGrid);
  const cv::Mat image = RenderOrDie(kGrid, Flat(0.5, 0.5));
  for (const Panel p : {Panel::kMean, Panel::kStdDev}) {
    const PixelRect& plot = layout.panel(p).plot;
    const PixelRect& bar = layout.panel(p).colour_bar;
    // x tick labels and name below the plot, y ones left of it, the colour
    // bar's right of it: some ink in each strip.
    const int below = plot.y + plot.height + 2;
    EXPECT_GT(DarkPixels(image, cv::Rect(plot.x, below, plot.width, layout.height - below)), 50);
    EXPECT_GT(DarkPixels(image, cv::Rect(plot.x - 40, plot.y, 38, plot.height)), 50);
    const int right = bar.x + bar.width + 2;
    EXPECT_GT(DarkPixels(image, cv::Rect(right, bar.y, 30, bar.height)), 50);
  }
}

TEST(MapRenderTest, TitleAddsALineOfText) {
  const MapLayout plain = LayoutOrDie(kGrid);
  const MapTitle title{"missions/m-000001", 42.0, 123.45};
  const MapLayout titled = LayoutOrDie(kGrid, {}, title);
  const int band = titled.panel(Panel::kMean).plot.y - plain.panel(Panel::kMean).plot.y;
  ASSERT_GT(band, 8);
  EXPECT_EQ(titled.height - plain.height, band);
  const cv::Mat image = RenderOrDie(kGrid, Flat(0.5, 0.5), {}, title);
  EXPECT_GT(DarkPixels(image, cv::Rect(0, 0, image.cols, band)), 100);
  const cv::Mat untitled = RenderOrDie(kGrid, Flat(0.5, 0.5));
  EXPECT_EQ(DarkPixels(untitled, cv::Rect(0, 0, untitled.cols, 6)), 0);
}

TEST(MapRenderTest, PathIsRedWithAWhiteStartInBothPanels) {
  Overlay overlay;
  overlay.path = {Vec2(-10.0, 0.0), Vec2(10.0, 0.0)};
  const MapLayout layout = LayoutOrDie(kGrid, overlay);
  const cv::Mat image = RenderOrDie(kGrid, Flat(0.0, 0.0), overlay);
  EXPECT_EQ(image.rows, layout.height);
  for (const Panel p : {Panel::kMean, Panel::kStdDev}) {
    const cv::Point on_path = PixelOf(WorldToPixel(kGrid, layout, p, Vec2(5.0, 0.0)));
    EXPECT_TRUE(AnyNear(image, on_path, 1, IsRed));
    const cv::Point start = PixelOf(WorldToPixel(kGrid, layout, p, Vec2(-10.0, 0.0)));
    EXPECT_TRUE(AnyNear(image, start, 1, IsWhite));
    // Away from the path the map is untouched.
    const cv::Point away = PixelOf(WorldToPixel(kGrid, layout, p, Vec2(5.0, 5.0)));
    EXPECT_EQ(At(image, away.x, away.y), Viridis(0));
  }
}

// A team's paths: each in its own colour (the palette's first two here,
// red and white, written out as RGB), none of them drawn over another's
// ground, and a legend entry per path, which widens nothing but the legend.
TEST(MapRenderTest, TeamPathsAreEachInTheirOwnColour) {
  EXPECT_EQ(TeamColour(0), (std::array<std::uint8_t, 3>{230, 25, 75}));
  EXPECT_EQ(TeamColour(1), (std::array<std::uint8_t, 3>{255, 255, 255}));
  EXPECT_EQ(TeamColour(8), TeamColour(0));  // the palette repeats past eight
  Overlay overlay;
  overlay.team_paths = {{.label = "north", .points = {Vec2(-10.0, 6.0), Vec2(10.0, 6.0)}},
                        {.label = "south", .points = {Vec2(-10.0, -6.0), Vec2(10.0, -6.0)}}};
  const MapLayout layout = LayoutOrDie(kGrid, overlay);
  const cv::Mat image = RenderOrDie(kGrid, Flat(0.0, 0.0), overlay);
  const auto is = [](std::array<std::uint8_t, 3> rgb) {
    return [rgb](const cv::Vec3b& bgr) {
      return std::abs(bgr[2] - rgb[0]) <= 20 && std::abs(bgr[1] - rgb[1]) <= 20 &&
             std::abs(bgr[0] - rgb[2]) <= 20;
    };
  };
  for (const Panel p : {Panel::kMean, Panel::kStdDev}) {
    const cv::Point north = PixelOf(WorldToPixel(kGrid, layout, p, Vec2(5.0, 6.0)));
    const cv::Point south = PixelOf(WorldToPixel(kGrid, layout, p, Vec2(5.0, -6.0)));
    EXPECT_TRUE(AnyNear(image, north, 1, is(TeamColour(0))));
    EXPECT_FALSE(AnyNear(image, north, 1, is(TeamColour(1))));
    EXPECT_TRUE(AnyNear(image, south, 1, is(TeamColour(1))));
    EXPECT_FALSE(AnyNear(image, south, 1, is(TeamColour(0))));
    const cv::Point away = PixelOf(WorldToPixel(kGrid, layout, p, Vec2(5.0, 0.0)));
    EXPECT_EQ(At(image, away.x, away.y), Viridis(0));
  }
  Overlay nan_team;
  nan_team.team_paths = {{.label = "a", .points = {Vec2(0, 0)}},
                         {.label = "b", .points = {Vec2(0, 0), Vec2(1, std::nan(""))}}};
  EXPECT_EQ(RenderMapPng(kGrid, Flat(0.0, 0.0), nan_team).status().message(),
            "overlay.team_paths[1][1]: must be finite, got (1, nan)");
}

TEST(MapRenderTest, TargetIsAGreenOutline) {
  Overlay overlay;
  overlay.targets = {{Vec2(2.0, 3.0), Vec2(6.0, 9.0)}};
  const MapLayout layout = LayoutOrDie(kGrid, overlay);
  const cv::Mat image = RenderOrDie(kGrid, Flat(0.0, 0.0), overlay);
  for (const Panel p : {Panel::kMean, Panel::kStdDev}) {
    for (const Vec2& edge : {Vec2(2.0, 6.0), Vec2(6.0, 6.0), Vec2(4.0, 3.0), Vec2(4.0, 9.0)}) {
      const cv::Point px = PixelOf(WorldToPixel(kGrid, layout, p, edge));
      EXPECT_TRUE(AnyNear(image, px, 1, IsGreen)) << edge.transpose();
    }
    const cv::Point inside = PixelOf(WorldToPixel(kGrid, layout, p, Vec2(4.0, 6.0)));
    EXPECT_EQ(At(image, inside.x, inside.y), Viridis(0));
  }
}

TEST(MapRenderTest, ObstacleFootprintIsShaded) {
  Overlay overlay;
  overlay.obstacle_footprints = {{Vec2(-9, 1), Vec2(1, 1), Vec2(1, 5), Vec2(-9, 5)}};
  const MapLayout layout = LayoutOrDie(kGrid, overlay);
  const cv::Mat image = RenderOrDie(kGrid, Flat(0.0, 0.0), overlay);
  const cv::Point inside = PixelOf(WorldToPixel(kGrid, layout, Panel::kMean, Vec2(-4, 3)));
  const cv::Point outside = PixelOf(WorldToPixel(kGrid, layout, Panel::kMean, Vec2(-4, -3)));
  EXPECT_NE(At(image, inside.x, inside.y), Viridis(0));
  EXPECT_EQ(At(image, outside.x, outside.y), Viridis(0));
}

TEST(MapRenderTest, SearchAreaRingsAreWhiteOutlinesThatShadeNothing) {
  Overlay overlay;
  overlay.search_area_rings = {Square(-9, 1, 1, 5)};
  const MapLayout layout = LayoutOrDie(kGrid, overlay);
  const cv::Mat image = RenderOrDie(kGrid, Flat(0.0, 0.0), overlay);
  for (const Panel panel : {Panel::kMean, Panel::kStdDev}) {
    // On each edge's middle; inside and outside the ring, the map.
    for (const Vec2& edge : {Vec2(-4, 1), Vec2(1, 3), Vec2(-4, 5), Vec2(-9, 3)}) {
      const cv::Point on = PixelOf(WorldToPixel(kGrid, layout, panel, edge));
      EXPECT_TRUE(AnyNear(image, on, 1, IsWhite)) << edge.transpose();
    }
    const cv::Point inside = PixelOf(WorldToPixel(kGrid, layout, panel, Vec2(-4, 3)));
    const cv::Point outside = PixelOf(WorldToPixel(kGrid, layout, panel, Vec2(-4, -3)));
    EXPECT_EQ(At(image, inside.x, inside.y), Viridis(0));
    EXPECT_EQ(At(image, outside.x, outside.y), Viridis(0));
  }
}

// The fence in yellow, a no-fly zone in pink: outlines on their edges, the
// map untouched inside and out.
TEST(MapRenderTest, TheFenceAndNoFlyZonesAreOutlinedInTheirColours) {
  Overlay overlay;
  overlay.fence_rings = {Square(-12, -12, 12, 12)};
  overlay.no_fly_footprints = {Square(-9, 1, 1, 5)};
  const MapLayout layout = LayoutOrDie(kGrid, overlay);
  const cv::Mat image = RenderOrDie(kGrid, Flat(0.0, 0.0), overlay);
  const auto near = [](const cv::Vec3b& want) {
    return [want](const cv::Vec3b& got) { return cv::norm(got, want, cv::NORM_INF) <= 40; };
  };
  for (const Panel panel : {Panel::kMean, Panel::kStdDev}) {
    for (const Vec2& edge : {Vec2(0, -12), Vec2(12, 0), Vec2(0, 12), Vec2(-12, 0)}) {
      const cv::Point on = PixelOf(WorldToPixel(kGrid, layout, panel, edge));
      EXPECT_TRUE(AnyNear(image, on, 1, near(cv::Vec3b(0, 230, 255)))) << edge.transpose();
    }
    for (const Vec2& edge : {Vec2(-4, 1), Vec2(1, 3), Vec2(-4, 5), Vec2(-9, 3)}) {
      const cv::Point on = PixelOf(WorldToPixel(kGrid, layout, panel, edge));
      EXPECT_TRUE(AnyNear(image, on, 1, near(cv::Vec3b(180, 105, 255)))) << edge.transpose();
    }
    const cv::Point inside = PixelOf(WorldToPixel(kGrid, layout, panel, Vec2(-4, 3)));
    const cv::Point outside = PixelOf(WorldToPixel(kGrid, layout, panel, Vec2(-4, -3)));
    EXPECT_EQ(At(image, inside.x, inside.y), Viridis(0));
    EXPECT_EQ(At(image, outside.x, outside.y), Viridis(0));
  }
}

// Home: a white pad with a black H at its point, in both panels, the map
// untouched 3 m away.
TEST(MapRenderTest, HomeIsAWhitePadWithABlackH) {
  Overlay overlay;
  overlay.home = Vec2(4, -6);
  const MapLayout layout = LayoutOrDie(kGrid, overlay);
  const cv::Mat image = RenderOrDie(kGrid, Flat(0.0, 0.0), overlay);
  const auto is_black = [](const cv::Vec3b& got) {
    return cv::norm(got, cv::Vec3b(0, 0, 0), cv::NORM_INF) <= 60;
  };
  for (const Panel panel : {Panel::kMean, Panel::kStdDev}) {
    const cv::Point centre = PixelOf(WorldToPixel(kGrid, layout, panel, Vec2(4, -6)));
    EXPECT_TRUE(AnyNear(image, centre, 1, is_black));  // the H's bar
    EXPECT_TRUE(AnyNear(image, centre, 6, IsWhite));   // the pad
    const cv::Point away = PixelOf(WorldToPixel(kGrid, layout, panel, Vec2(4, -3)));
    EXPECT_EQ(At(image, away.x, away.y), Viridis(0));
  }
}

TEST(MapRenderTest, SameInputsGiveTheSameBytes) {
  MapLayers layers = Flat(0.0, 1.0);
  for (int i = 0; i < kN * kN; ++i) {
    layers.mean[i] = (i % 97) / 96.0;
    layers.std_dev[i] = 1.0 - (i % 13) / 12.0;
  }
  Overlay overlay;
  overlay.obstacle_footprints = {{Vec2(-9, 1), Vec2(1, 1), Vec2(1, 5), Vec2(-9, 5)}};
  overlay.targets = {{Vec2(2.0, 3.0), Vec2(2.75, 5.0)}};
  overlay.path = {Vec2(-12, -11), Vec2(12, -11), Vec2(12, -4), Vec2(-12.3, -4.1)};
  overlay.planned_path = {Vec2(-12.3, -4.1), Vec2(0, 10)};
  overlay.detections = {Vec2(2.4, 4.0)};
  const MapTitle title{"missions/m-000001", 42.0, 123.45};
  const absl::StatusOr<std::string> a = RenderMapPng(kGrid, layers, overlay, title);
  const absl::StatusOr<std::string> b = RenderMapPng(kGrid, layers, overlay, title);
  ASSERT_TRUE(a.ok()) << a.status();
  ASSERT_TRUE(b.ok()) << b.status();
  EXPECT_EQ(*a, *b);
  EXPECT_EQ(a->substr(1, 3), "PNG");
}

TEST(MapRenderTest, BadInputsAreNamed) {
  const auto error = [](const MapGrid& grid, const MapLayers& layers, const Overlay& overlay = {}) {
    const absl::StatusOr<std::string> png = RenderMapPng(grid, layers, overlay);
    EXPECT_EQ(png.status().code(), absl::StatusCode::kInvalidArgument);
    return std::string(png.status().message());
  };
  MapLayers short_mean = Flat(0.5, 0.5);
  short_mean.mean.resize(10);
  EXPECT_THAT(error(kGrid, short_mean), HasSubstr("mean: has 10 values, expected 1600"));
  MapLayers short_std = Flat(0.5, 0.5);
  short_std.std_dev.resize(1599);
  EXPECT_THAT(error(kGrid, short_std), HasSubstr("std_dev: has 1599 values, expected 1600"));

  const MapLayers ok = Flat(0.5, 0.5);
  EXPECT_THAT(error({0, kN, kRes, kMin, kMin}, ok), HasSubstr("nx"));
  EXPECT_THAT(error({kN, -1, kRes, kMin, kMin}, ok), HasSubstr("ny"));
  EXPECT_THAT(error({kN, kN, 0.0, kMin, kMin}, ok), HasSubstr("resolution_m"));
  EXPECT_THAT(error({kN, kN, std::nan(""), kMin, kMin}, ok), HasSubstr("resolution_m"));
  EXPECT_THAT(error({kN, kN, std::numeric_limits<double>::infinity(), kMin, kMin}, ok),
              HasSubstr("resolution_m"));
  EXPECT_THAT(error({kN, kN, kRes, std::nan(""), kMin}, ok), HasSubstr("x_min_m"));
  EXPECT_THAT(error({kN, kN, kRes, kMin, std::nan("")}, ok), HasSubstr("y_min_m"));

  Overlay two_vertices;
  two_vertices.obstacle_footprints = {{Vec2(0, 0), Vec2(1, 1)}};
  EXPECT_THAT(error(kGrid, ok, two_vertices), HasSubstr("overlay.obstacle_footprints[0]"));
  Overlay open_ring;
  open_ring.search_area_rings = {Square(-9, 1, 1, 5), {Vec2(0, 0), Vec2(1, 1)}};
  EXPECT_THAT(error(kGrid, ok, open_ring), HasSubstr("overlay.search_area_rings[1]"));
  Overlay open_fence;
  open_fence.fence_rings = {{Vec2(0, 0), Vec2(1, 1)}};
  EXPECT_THAT(error(kGrid, ok, open_fence), HasSubstr("overlay.fence_rings[0]"));
  Overlay nan_zone;
  nan_zone.no_fly_footprints = {{Vec2(0, 0), Vec2(1, 1), Vec2(std::nan(""), 0)}};
  EXPECT_THAT(error(kGrid, ok, nan_zone), HasSubstr("overlay.no_fly_footprints[0]"));
  Overlay nan_home;
  nan_home.home = Vec2(std::nan(""), 0);
  EXPECT_THAT(error(kGrid, ok, nan_home), HasSubstr("overlay.home"));
  Overlay nan_path;
  nan_path.path = {Vec2(0, 0), Vec2(std::nan(""), 1)};
  EXPECT_THAT(error(kGrid, ok, nan_path), HasSubstr("overlay.path[1]"));

  EXPECT_EQ(ComputeMapLayout({0, 1, 1.0, 0, 0}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(MapRenderTest, TinyGridStillRenders) {
  const MapGrid grid{1, 1, 1.0, 0.0, 0.0};
  const MapLayout layout = LayoutOrDie(grid);
  const cv::Mat image = RenderOrDie(grid, {{1.0}, {0.0}});
  EXPECT_EQ(image.cols, layout.width);
  EXPECT_EQ(image.rows, layout.height);
  const PixelRect& plot = layout.panel(Panel::kMean).plot;
  EXPECT_EQ(At(image, plot.x + 4, plot.y + 4), Viridis(255));
}

}  // namespace
}  // namespace oaipp::render
