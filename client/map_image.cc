#include "client/map_image.h"

#include <algorithm>
#include <cmath>

#include "opencv2/imgcodecs.hpp"
#include "opencv2/imgproc.hpp"

namespace oaipp::client {
namespace {

constexpr int kCellPx = 12;
constexpr int kGapPx = 12;

}  // namespace

absl::StatusOr<std::string> RenderMissionPng(const v1::GetMapResponse& map,
                                             const Simulation& simulation,
                                             const std::vector<Vec3>& path_W) {
  const int nx = map.nx(), ny = map.ny();
  if (nx <= 0 || ny <= 0 || map.mean_size() != nx * ny || map.variance_size() != nx * ny) {
    return absl::InvalidArgumentError("map: needs its cells (GetMap with include_cells)");
  }
  const int w = nx * kCellPx, h = ny * kCellPx;
  cv::Mat canvas(h, 2 * w + kGapPx, CV_8UC3, cv::Scalar(255, 255, 255));
  for (int panel = 0; panel < 2; ++panel) {
    cv::Mat values(ny, nx, CV_8UC1);
    for (int row = 0; row < ny; ++row) {
      for (int col = 0; col < nx; ++col) {
        const int cell = row * nx + col;
        const double v = panel == 0 ? map.mean(cell) : std::sqrt(std::max(0.0, map.variance(cell)));
        // Row 0 of the image is the northernmost row of cells.
        values.at<std::uint8_t>(ny - 1 - row, col) =
            static_cast<std::uint8_t>(std::lround(255.0 * std::clamp(v, 0.0, 1.0)));
      }
    }
    cv::Mat big, colour;
    cv::resize(values, big, cv::Size(w, h), 0, 0, cv::INTER_NEAREST);
    cv::applyColorMap(big, colour, cv::COLORMAP_VIRIDIS);
    colour.copyTo(canvas(cv::Rect(panel * (w + kGapPx), 0, w, h)));
  }
  const double res = map.resolution_m();
  auto to_px = [&](double x, double y, int panel) {
    return cv::Point(
        static_cast<int>(std::lround((x - map.x_min_m()) / res * kCellPx)) + panel * (w + kGapPx),
        static_cast<int>(std::lround(h - (y - map.y_min_m()) / res * kCellPx)));
  };
  for (int panel = 0; panel < 2; ++panel) {
    for (const auto& [id, o] : simulation.environment().obstacles()) {
      const Aabb box = BoundingBox(o.shape);
      cv::rectangle(canvas, to_px(box.min_W.x(), box.min_W.y(), panel),
                    to_px(box.max_W.x(), box.max_W.y(), panel), cv::Scalar(160, 160, 160), 2);
    }
    for (const auto& [lo, hi] : simulation.TargetRectangles()) {
      cv::rectangle(canvas, to_px(lo.x(), lo.y(), panel), to_px(hi.x(), hi.y(), panel),
                    cv::Scalar(0, 200, 0), 2);
    }
    std::vector<cv::Point> line;
    for (const Vec3& p : path_W) line.push_back(to_px(p.x(), p.y(), panel));
    if (line.size() >= 2) cv::polylines(canvas, line, false, cv::Scalar(0, 0, 230), 2, cv::LINE_AA);
    if (!line.empty()) cv::circle(canvas, line.front(), 5, cv::Scalar(255, 255, 255), -1);
  }
  std::vector<std::uint8_t> png;
  if (!cv::imencode(".png", canvas, png))
    return absl::InternalError("map image: PNG encoding failed");
  return std::string(png.begin(), png.end());
}

}  // namespace oaipp::client
