#include "render/map_render.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "opencv2/core.hpp"
#include "opencv2/imgproc.hpp"
#include "render/labels.h"
#include "render/map_checks.h"
#include "render/png.h"

namespace oaipp::render {
namespace {

using labels::Font;
using labels::HAlign;
using labels::kBlack;
using labels::kWhite;
using labels::MakeTicks;
using labels::MeasureText;
using labels::PutText;
using labels::PutTextUp;
using labels::TextExtent;
using labels::Tick;
using labels::Ticks;
using labels::UpTextWidth;
using labels::VAlign;

// ---------------------------------------------------------------------------
// Colours (OpenCV order: blue, green, red).

const cv::Scalar kObstacleFill(150, 150, 150);
const cv::Scalar kObstacleEdge(80, 80, 80);
const cv::Scalar kTargetColour(0, 200, 0);
const cv::Scalar kPathColour(0, 0, 230);
const cv::Scalar kPlannedColour(230, 0, 230);
const cv::Scalar kDetectionColour(0, 140, 255);
const cv::Scalar kFenceColour(0, 230, 255);    // yellow
const cv::Scalar kNoFlyColour(180, 105, 255);  // pink
constexpr double kObstacleFillAlpha = 0.6;     // share of grey over the map

constexpr int kSubpixelBits = 4;  // fixed-point shift for overlay drawing
constexpr double kSubpixel = 1 << kSubpixelBits;

// ---------------------------------------------------------------------------
// Layout.

enum class LegendKind {
  kSearchArea,
  kFence,
  kNoFly,
  kObstacle,
  kTarget,
  kPath,
  kPlannedPath,
  kDetection,
  kTeamPath,
  kHome
};

struct LegendItem {
  LegendKind kind;
  std::string text;
  std::size_t team_index = 0;  // kTeamPath: which colour
  int x = 0;                   // left of the swatch
};

// TeamColour(i) as OpenCV's blue, green, red.
cv::Scalar TeamScalar(std::size_t i) {
  const std::array<std::uint8_t, 3> rgb = TeamColour(i);
  return cv::Scalar(rgb[2], rgb[1], rgb[0]);
}

constexpr const char* kPanelHeading[2] = {"mean", "standard deviation"};
constexpr const char* kBarName[2] = {"mean", "std. dev."};
constexpr const char* kXName = "x [m]";
constexpr const char* kYName = "y [m]";

// Everything the drawing needs, worked out once from the inputs' shapes.
struct Geometry {
  MapLayout layout;
  double unit = 1.0;  // scales fonts, margins and line widths with the image
  Font body;
  Font heading;
  Font title_font;
  int pad = 6;
  int tick_px = 5;
  int line_px = 2;
  std::vector<Tick> x_ticks;
  std::vector<Tick> y_ticks;
  std::vector<Tick> bar_ticks;
  std::string title;
  int title_top = 0;
  int heading_top = 0;
  int x_labels_top = 0;
  int x_name_top = 0;
  std::array<int, 2> y_name_x{};    // centre column of "y [m]" per panel
  std::array<int, 2> bar_name_x{};  // centre column of the bar name per panel
  int swatch_w = 22;
  int swatch_h = 12;
  int legend_middle = 0;  // row through the middle of the legend line
  std::vector<LegendItem> legend;
};

std::string TitleText(const MapTitle& title) {
  std::vector<std::string> parts;
  if (!title.mission.empty()) parts.push_back(title.mission);
  char buffer[64];
  if (title.mission_time_s.has_value()) {
    std::snprintf(buffer, sizeof(buffer), "t = %.1f s", *title.mission_time_s);
    parts.emplace_back(buffer);
  }
  if (title.trace.has_value()) {
    std::snprintf(buffer, sizeof(buffer), "Tr(P) = %.2f", *title.trace);
    parts.emplace_back(buffer);
  }
  std::string text;
  for (const std::string& part : parts) absl::StrAppend(&text, text.empty() ? "" : "    ", part);
  return text;
}

std::vector<LegendItem> LegendItems(const Overlay& overlay) {
  std::vector<LegendItem> items;
  if (!overlay.search_area_rings.empty()) {
    items.push_back({LegendKind::kSearchArea, "search area"});
  }
  if (!overlay.fence_rings.empty()) items.push_back({LegendKind::kFence, "fence"});
  if (!overlay.no_fly_footprints.empty()) items.push_back({LegendKind::kNoFly, "no-fly zone"});
  if (!overlay.obstacle_footprints.empty()) items.push_back({LegendKind::kObstacle, "obstacle"});
  if (!overlay.targets.empty()) items.push_back({LegendKind::kTarget, "target"});
  if (!overlay.path.empty()) {
    items.push_back({LegendKind::kPath, absl::StrCat(overlay.path_label, " (dot: start)")});
  }
  for (std::size_t i = 0; i < overlay.team_paths.size(); ++i) {
    items.push_back({LegendKind::kTeamPath, overlay.team_paths[i].label, i});
  }
  if (!overlay.planned_path.empty()) items.push_back({LegendKind::kPlannedPath, "planned path"});
  if (!overlay.detections.empty()) items.push_back({LegendKind::kDetection, "detection"});
  if (overlay.home.has_value()) items.push_back({LegendKind::kHome, "home"});
  return items;
}

absl::StatusOr<Geometry> MakeGeometry(const MapGrid& grid, const Overlay& overlay,
                                      const MapTitle& title) {
  if (absl::Status s = ValidateGrid(grid); !s.ok()) return s;
  if (absl::Status s = ValidateOverlay(overlay); !s.ok()) return s;

  Geometry g;
  MapLayout& layout = g.layout;
  const int k = std::clamp(kMaxPanelPx / std::max(grid.nx, grid.ny), 1, kMaxCellPx);
  const int plot_w = grid.nx * k;
  const int plot_h = grid.ny * k;
  layout.cell_px = k;

  // Text and lines grow with the panel so that they stay readable when the
  // picture is shown scaled down.
  g.unit = std::clamp(std::max(plot_w, plot_h) / 480.0, 1.0, 2.6);
  const double u = g.unit;
  const int bold = u >= 1.7 ? 2 : 1;
  g.body = {0.45 * u, bold};
  g.heading = {0.55 * u, bold};
  g.title_font = {0.6 * u, u >= 1.4 ? 2 : 1};
  g.pad = static_cast<int>(std::lround(6 * u));
  g.tick_px = static_cast<int>(std::lround(5 * u));
  g.line_px = static_cast<int>(std::lround(2 * u));
  g.swatch_w = static_cast<int>(std::lround(24 * u));
  g.swatch_h = static_cast<int>(std::lround(12 * u));
  const int margin = static_cast<int>(std::lround(12 * u));
  const int bar_gap = static_cast<int>(std::lround(14 * u));
  const int bar_w = static_cast<int>(std::lround(16 * u));
  const int bar_h = std::max(plot_h, static_cast<int>(std::lround(100 * u)));
  const TextExtent digit = MeasureText("0", g.body);
  const int body_line = digit.cap + digit.descent;

  // Ticks: x labels side by side need their width plus a gap, y labels and
  // colour bar labels one above the other need about two lines.
  const auto width_plus_gap = [&](const std::string& s) {
    return MeasureText(s, g.body).width + 2 * g.pad;
  };
  const auto line_gap = [&](const std::string&) { return 2 * body_line; };
  const double x_max = grid.x_min_m + grid.nx * grid.resolution_m;
  const double y_max = grid.y_min_m + grid.ny * grid.resolution_m;
  Ticks x_ticks = MakeTicks(grid.x_min_m, x_max, plot_w, 48 * u, width_plus_gap);
  Ticks y_ticks = MakeTicks(grid.y_min_m, y_max, plot_h, 30 * u, line_gap);
  // Both axes have the same metres per pixel: give them the same step.
  if (x_ticks.step < y_ticks.step) {
    x_ticks = MakeTicks(grid.x_min_m, x_max, plot_w, 48 * u, width_plus_gap, y_ticks.step);
  } else if (y_ticks.step < x_ticks.step) {
    y_ticks = MakeTicks(grid.y_min_m, y_max, plot_h, 30 * u, line_gap, x_ticks.step);
  }
  g.x_ticks = std::move(x_ticks.ticks);
  g.y_ticks = std::move(y_ticks.ticks);
  g.bar_ticks = MakeTicks(0.0, 1.0, bar_h, std::max(30 * u, bar_h / 6.0), line_gap).ticks;
  int y_label_w = 0;
  for (const Tick& t : g.y_ticks) {
    y_label_w = std::max(y_label_w, MeasureText(t.label, g.body).width);
  }
  int bar_label_w = 0;
  for (const Tick& t : g.bar_ticks) {
    bar_label_w = std::max(bar_label_w, MeasureText(t.label, g.body).width);
  }
  const int y_name_w = UpTextWidth(kYName, g.body);
  const int bar_name_w =
      std::max(UpTextWidth(kBarName[0], g.body), UpTextWidth(kBarName[1], g.body));

  // Top to bottom: title, panel headings, plots (framed by one pixel), x
  // tick labels, x axis name, legend.
  int y = margin;
  g.title = TitleText(title);
  int title_w = 0;
  if (!g.title.empty()) {
    const TextExtent e = MeasureText(g.title, g.title_font);
    g.title_top = y;
    title_w = e.width;
    y += e.cap + e.descent + g.pad;
  }
  g.heading_top = y;
  const TextExtent heading = MeasureText(kPanelHeading[1], g.heading);
  y += heading.cap + heading.descent + g.pad;
  const int plot_y = y + 1;
  g.x_labels_top = plot_y + plot_h + 1 + g.tick_px + g.pad / 2;
  g.x_name_top = g.x_labels_top + body_line + g.pad;
  int bottom = std::max(g.x_name_top + body_line, plot_y + bar_h + body_line);

  g.legend = LegendItems(overlay);
  if (!g.legend.empty()) {
    const int line_h = std::max(body_line, g.swatch_h);
    g.legend_middle = bottom + 2 * g.pad + line_h / 2;
    bottom = g.legend_middle + line_h - line_h / 2;
  }
  layout.height = bottom + margin;

  // Left to right within a panel: y axis name, y tick labels, ticks, plot,
  // colour bar, its ticks, its labels, its name.
  int panel_w = 0;
  for (int p = 0; p < 2; ++p) {
    const int x0 = p * panel_w;
    const int plot_x = x0 + margin + y_name_w + g.pad + y_label_w + g.pad / 2 + g.tick_px + 1;
    const int bar_x = plot_x + plot_w + 1 + bar_gap + 1;
    const int bar_label_x = bar_x + bar_w + 1 + g.tick_px + g.pad / 2;
    g.y_name_x[p] = x0 + margin + y_name_w / 2;
    g.bar_name_x[p] = bar_label_x + bar_label_w + g.pad + bar_name_w / 2;
    layout.panels[p].plot = {plot_x, plot_y, plot_w, plot_h};
    layout.panels[p].colour_bar = {bar_x, plot_y, bar_w, bar_h};
    if (p == 0) panel_w = bar_label_x + bar_label_w + g.pad + bar_name_w + margin;
  }
  // The title and the legend start at the left edge of the first plot.
  const int text_left = layout.panels[0].plot.x;
  int legend_right = 0;
  int x = text_left;
  for (LegendItem& item : g.legend) {
    item.x = x;
    legend_right = x + g.swatch_w + g.pad + MeasureText(item.text, g.body).width;
    x = legend_right + 3 * g.pad;
  }
  layout.width = std::max({2 * panel_w, text_left + title_w + margin, legend_right + margin});
  return g;
}

// ---------------------------------------------------------------------------
// Drawing.

std::uint8_t Level(double v) {
  if (std::isnan(v)) return 0;
  return static_cast<std::uint8_t>(std::lround(255.0 * std::clamp(v, 0.0, 1.0)));
}

cv::Rect ToCv(const PixelRect& r) { return {r.x, r.y, r.width, r.height}; }

// Fills `plot` with the cells' viridis colours, k x k pixels each, north up.
void PaintCells(cv::Mat& canvas, const PixelRect& plot, const MapGrid& grid,
                const std::vector<double>& values, int k) {
  cv::Mat levels(grid.ny, grid.nx, CV_8UC1);
  for (int row = 0; row < grid.ny; ++row) {
    for (int col = 0; col < grid.nx; ++col) {
      levels.at<std::uint8_t>(grid.ny - 1 - row, col) = Level(values[row * grid.nx + col]);
    }
  }
  cv::Mat colours;
  cv::applyColorMap(levels, colours, cv::COLORMAP_VIRIDIS);
  for (int r = 0; r < plot.height; ++r) {
    const cv::Vec3b* from = colours.ptr<cv::Vec3b>(r / k);
    cv::Vec3b* to = canvas.ptr<cv::Vec3b>(plot.y + r) + plot.x;
    for (int c = 0; c < plot.width; ++c) to[c] = from[c / k];
  }
}

// A world point as a fixed-point OpenCV point inside the plot (origin at the
// plot's top-left pixel; OpenCV puts pixel centres on integers).
cv::Point PlotPoint(const MapGrid& grid, int k, int plot_h, const Vec2& p_W) {
  const double x = (p_W.x() - grid.x_min_m) / grid.resolution_m * k;
  const double y = plot_h - (p_W.y() - grid.y_min_m) / grid.resolution_m * k;
  const auto fixed = [](double v) {
    return static_cast<int>(std::lround(std::clamp(v - 0.5, -1e7, 1e7) * kSubpixel));
  };
  return {fixed(x), fixed(y)};
}

void DrawStartDot(cv::Mat& image, cv::Point centre_fixed, int radius_px) {
  const int r = radius_px << kSubpixelBits;
  cv::circle(image, centre_fixed, r, kWhite, cv::FILLED, cv::LINE_AA, kSubpixelBits);
  cv::circle(image, centre_fixed, r, kBlack, 1, cv::LINE_AA, kSubpixelBits);
}

void DrawDetection(cv::Mat& image, cv::Point centre_fixed, int radius_px) {
  const int r = radius_px << kSubpixelBits;
  cv::circle(image, centre_fixed, r, kDetectionColour, cv::FILLED, cv::LINE_AA, kSubpixelBits);
  cv::circle(image, centre_fixed, r, kBlack, 1, cv::LINE_AA, kSubpixelBits);
}

// A landing pad: a white square, black edged, with a black H, about
// 2.5 radius_px across.
void DrawHome(cv::Mat& image, cv::Point centre_fixed, int radius_px) {
  const int r = (radius_px + radius_px / 4) << kSubpixelBits;
  const cv::Point half(r, r);
  cv::rectangle(image, centre_fixed - half, centre_fixed + half, kWhite, cv::FILLED, cv::LINE_AA,
                kSubpixelBits);
  cv::rectangle(image, centre_fixed - half, centre_fixed + half, kBlack, 1, cv::LINE_AA,
                kSubpixelBits);
  const int h = r / 2;
  const int w = std::max(2, radius_px / 4);
  for (const int side : {-h, h}) {
    cv::line(image, centre_fixed + cv::Point(side, -h), centre_fixed + cv::Point(side, h), kBlack,
             w, cv::LINE_AA, kSubpixelBits);
  }
  cv::line(image, centre_fixed + cv::Point(-h, 0), centre_fixed + cv::Point(h, 0), kBlack, w,
           cv::LINE_AA, kSubpixelBits);
}

void DrawOverlay(cv::Mat& canvas, const PixelRect& plot, const MapGrid& grid, int k,
                 const Overlay& overlay, const Geometry& g) {
  cv::Mat area = canvas(ToCv(plot));  // drawing here clips to the plot
  const auto points = [&](const std::vector<Vec2>& world) {
    std::vector<cv::Point> out;
    out.reserve(world.size());
    for (const Vec2& p : world) out.push_back(PlotPoint(grid, k, plot.height, p));
    return out;
  };
  if (!overlay.obstacle_footprints.empty()) {
    std::vector<std::vector<cv::Point>> polygons;
    for (const auto& footprint : overlay.obstacle_footprints) polygons.push_back(points(footprint));
    cv::Mat mask(area.size(), CV_8UC1, cv::Scalar(0));
    cv::fillPoly(mask, polygons, cv::Scalar(255), cv::LINE_8, kSubpixelBits);
    cv::Mat grey(area.size(), CV_8UC3, kObstacleFill);
    cv::Mat shaded;
    cv::addWeighted(area, 1.0 - kObstacleFillAlpha, grey, kObstacleFillAlpha, 0.0, shaded);
    shaded.copyTo(area, mask);
    cv::polylines(area, polygons, true, kObstacleEdge, g.line_px, cv::LINE_AA, kSubpixelBits);
  }
  const auto outlines = [&](const std::vector<std::vector<Vec2>>& world, const cv::Scalar& colour) {
    if (world.empty()) return;
    std::vector<std::vector<cv::Point>> rings;
    for (const auto& ring : world) rings.push_back(points(ring));
    cv::polylines(area, rings, true, colour, g.line_px, cv::LINE_AA, kSubpixelBits);
  };
  outlines(overlay.search_area_rings, kWhite);
  outlines(overlay.no_fly_footprints, kNoFlyColour);
  outlines(overlay.fence_rings, kFenceColour);
  for (const auto& [lo, hi] : overlay.targets) {
    cv::rectangle(area, PlotPoint(grid, k, plot.height, lo), PlotPoint(grid, k, plot.height, hi),
                  kTargetColour, g.line_px, cv::LINE_8, kSubpixelBits);
  }
  const auto polyline = [&](const std::vector<Vec2>& world, const cv::Scalar& colour) {
    const std::vector<cv::Point> line = points(world);
    if (line.size() >= 2) {
      cv::polylines(area, line, false, colour, g.line_px, cv::LINE_AA, kSubpixelBits);
    }
  };
  polyline(overlay.planned_path, kPlannedColour);
  polyline(overlay.path, kPathColour);
  for (std::size_t i = 0; i < overlay.team_paths.size(); ++i) {
    polyline(overlay.team_paths[i].points, TeamScalar(i));
  }
  const int dot_px = static_cast<int>(std::lround(4 * g.unit));
  if (!overlay.path.empty()) {
    DrawStartDot(area, PlotPoint(grid, k, plot.height, overlay.path.front()), dot_px);
  }
  for (const Overlay::LabelledPath& path : overlay.team_paths) {
    if (path.points.empty()) continue;
    DrawStartDot(area, PlotPoint(grid, k, plot.height, path.points.front()), dot_px);
  }
  for (const Vec2& p : overlay.detections) {
    DrawDetection(area, PlotPoint(grid, k, plot.height, p), dot_px - 1);
  }
  if (overlay.home.has_value()) {
    DrawHome(area, PlotPoint(grid, k, plot.height, *overlay.home), dot_px + 3);
  }
}

// One-pixel black frame just outside `r`.
void Frame(cv::Mat& canvas, const PixelRect& r) {
  cv::rectangle(canvas, cv::Point(r.x - 1, r.y - 1), cv::Point(r.x + r.width, r.y + r.height),
                kBlack, 1, cv::LINE_8);
}

// Pixel column / row of a tick inside [first, first + span).
int TickPixel(double pixel, int first, int span) {
  return std::clamp(static_cast<int>(std::floor(pixel)), first, first + span - 1);
}

void DrawAxes(cv::Mat& canvas, const MapGrid& grid, const Geometry& g, int p) {
  const PixelRect& plot = g.layout.panels[p].plot;
  const int k = g.layout.cell_px;
  Frame(canvas, plot);
  const int bottom = plot.y + plot.height;  // the frame's row
  for (const Tick& t : g.x_ticks) {
    const int col =
        TickPixel(plot.x + (t.value - grid.x_min_m) / grid.resolution_m * k, plot.x, plot.width);
    cv::line(canvas, {col, bottom}, {col, bottom + g.tick_px}, kBlack, 1, cv::LINE_8);
    PutText(canvas, t.label, col, g.x_labels_top, HAlign::kCentre, VAlign::kTop, g.body);
  }
  PutText(canvas, kXName, plot.x + plot.width / 2, g.x_name_top, HAlign::kCentre, VAlign::kTop,
          g.body);
  const int left = plot.x - 1;  // the frame's column
  for (const Tick& t : g.y_ticks) {
    const int row =
        TickPixel(plot.y + plot.height - (t.value - grid.y_min_m) / grid.resolution_m * k, plot.y,
                  plot.height);
    cv::line(canvas, {left - g.tick_px, row}, {left, row}, kBlack, 1, cv::LINE_8);
    PutText(canvas, t.label, left - g.tick_px - g.pad / 2, row, HAlign::kRight, VAlign::kMiddle,
            g.body);
  }
  // Centred on the plot, but never above its top (tiny grids).
  const int y_name_length = MeasureText(kYName, g.body).width + 2 * (g.body.thickness + 1);
  PutTextUp(canvas, kYName, g.y_name_x[p], plot.y + std::max(plot.height, y_name_length) / 2,
            g.body);
  PutText(canvas, kPanelHeading[p], plot.x + plot.width / 2, g.heading_top, HAlign::kCentre,
          VAlign::kTop, g.heading);
}

// Viridis from 1 (top row) to 0 (bottom row), ticks and labels on its right
// and its name turned upwards beyond them.
void DrawColourBar(cv::Mat& canvas, const Geometry& g, int p) {
  const PixelRect& bar = g.layout.panels[p].colour_bar;
  cv::Mat levels(bar.height, 1, CV_8UC1);
  for (int r = 0; r < bar.height; ++r) {
    const double v = bar.height > 1 ? 1.0 - static_cast<double>(r) / (bar.height - 1) : 1.0;
    levels.at<std::uint8_t>(r, 0) = Level(v);
  }
  cv::Mat colours;
  cv::applyColorMap(levels, colours, cv::COLORMAP_VIRIDIS);
  for (int r = 0; r < bar.height; ++r) {
    canvas(cv::Rect(bar.x, bar.y + r, bar.width, 1)).setTo(cv::Scalar(colours.at<cv::Vec3b>(r, 0)));
  }
  Frame(canvas, bar);
  const int right = bar.x + bar.width;  // the frame's column
  for (const Tick& t : g.bar_ticks) {
    const int row = bar.y + static_cast<int>(std::lround((1.0 - t.value) * (bar.height - 1)));
    cv::line(canvas, {right, row}, {right + g.tick_px, row}, kBlack, 1, cv::LINE_8);
    PutText(canvas, t.label, right + g.tick_px + g.pad / 2 + 1, row, HAlign::kLeft, VAlign::kMiddle,
            g.body);
  }
  PutTextUp(canvas, kBarName[p], g.bar_name_x[p], bar.y + bar.height / 2, g.body);
}

void DrawLegend(cv::Mat& canvas, const Geometry& g) {
  const int mid = g.legend_middle;
  const int half_h = g.swatch_h / 2;
  for (const LegendItem& item : g.legend) {
    const cv::Rect swatch(item.x, mid - half_h, g.swatch_w, g.swatch_h);
    const cv::Point left(swatch.x, mid), right(swatch.x + swatch.width - 1, mid);
    const auto fixed = [](cv::Point q) { return q * static_cast<int>(kSubpixel); };
    const int dot_px = static_cast<int>(std::lround(4 * g.unit));
    switch (item.kind) {
      case LegendKind::kSearchArea:  // outlined: the legend's ground is white
        cv::rectangle(canvas, swatch, kBlack, g.line_px + 2);
        cv::rectangle(canvas, swatch, kWhite, g.line_px);
        break;
      case LegendKind::kFence:
        cv::rectangle(canvas, swatch, kFenceColour, g.line_px);
        break;
      case LegendKind::kNoFly:
        cv::rectangle(canvas, swatch, kNoFlyColour, g.line_px);
        break;
      case LegendKind::kObstacle:
        cv::rectangle(canvas, swatch, kObstacleFill, cv::FILLED);
        cv::rectangle(canvas, swatch, kObstacleEdge, g.line_px);
        break;
      case LegendKind::kTarget:
        cv::rectangle(canvas, swatch, kTargetColour, g.line_px);
        break;
      case LegendKind::kPath:
        cv::line(canvas, left, right, kPathColour, g.line_px, cv::LINE_AA);
        DrawStartDot(canvas, fixed(left + cv::Point(dot_px, 0)), dot_px);
        break;
      case LegendKind::kPlannedPath:
        cv::line(canvas, left, right, kPlannedColour, g.line_px, cv::LINE_AA);
        break;
      case LegendKind::kTeamPath:  // outlined: white and black are in the palette
        cv::line(canvas, left, right, kBlack, g.line_px + 2, cv::LINE_AA);
        cv::line(canvas, left, right, TeamScalar(item.team_index), g.line_px, cv::LINE_AA);
        DrawStartDot(canvas, fixed(left + cv::Point(dot_px, 0)), dot_px);
        break;
      case LegendKind::kDetection:
        DrawDetection(canvas, fixed((left + right) / 2), dot_px - 1);
        break;
      case LegendKind::kHome:
        DrawHome(canvas, fixed((left + right) / 2), dot_px + 1);
        break;
    }
    PutText(canvas, item.text, swatch.x + swatch.width + g.pad, mid, HAlign::kLeft, VAlign::kMiddle,
            g.body);
  }
}

}  // namespace

absl::StatusOr<MapLayout> ComputeMapLayout(const MapGrid& grid, const Overlay& overlay,
                                           const MapTitle& title) {
  try {
    absl::StatusOr<Geometry> g = MakeGeometry(grid, overlay, title);
    if (!g.ok()) return g.status();
    return g->layout;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("map layout: ", e.what()));
  }
}

Vec2 WorldToPixel(const MapGrid& grid, const MapLayout& layout, Panel panel, const Vec2& p_W) {
  const PixelRect& plot = layout.panel(panel).plot;
  const double k = layout.cell_px;
  return {plot.x + (p_W.x() - grid.x_min_m) / grid.resolution_m * k,
          plot.y + plot.height - (p_W.y() - grid.y_min_m) / grid.resolution_m * k};
}

std::array<std::uint8_t, 3> TeamColour(std::size_t i) {
  // Red, white, orange, pink, black, cyan, brown, lavender: none of them on
  // viridis's purple-blue-green-yellow ramp.
  static constexpr std::array<std::array<std::uint8_t, 3>, 8> kColours = {{{230, 25, 75},
                                                                           {255, 255, 255},
                                                                           {245, 130, 48},
                                                                           {240, 50, 230},
                                                                           {0, 0, 0},
                                                                           {70, 240, 240},
                                                                           {170, 110, 40},
                                                                           {220, 190, 255}}};
  return kColours[i % kColours.size()];
}

absl::StatusOr<std::string> RenderMapPng(const MapGrid& grid, const MapLayers& layers,
                                         const Overlay& overlay, const MapTitle& title) {
  try {
    absl::StatusOr<Geometry> made = MakeGeometry(grid, overlay, title);
    if (!made.ok()) return made.status();
    if (absl::Status s = ValidateLayers(grid, layers); !s.ok()) return s;
    const Geometry& g = *made;
    const MapLayout& layout = g.layout;

    cv::Mat canvas(layout.height, layout.width, CV_8UC3, kWhite);
    const std::vector<double>* values[2] = {&layers.mean, &layers.std_dev};
    for (int p = 0; p < 2; ++p) {
      const PixelRect& plot = layout.panels[p].plot;
      PaintCells(canvas, plot, grid, *values[p], layout.cell_px);
      DrawOverlay(canvas, plot, grid, layout.cell_px, overlay, g);
      DrawAxes(canvas, grid, g, p);
      DrawColourBar(canvas, g, p);
    }
    if (!g.title.empty()) {
      PutText(canvas, g.title, layout.panels[0].plot.x, g.title_top, HAlign::kLeft, VAlign::kTop,
              g.title_font);
    }
    DrawLegend(canvas, g);

    return EncodePngBgr(canvas.ptr<std::uint8_t>(), canvas.cols, canvas.rows, canvas.step);
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("map png: ", e.what()));
  }
}

}  // namespace oaipp::render
