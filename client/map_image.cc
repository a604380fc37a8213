#include "client/map_image.h"

#include <algorithm>
#include <cmath>

#include "core/common/status_macros.h"
#include "opencv2/imgcodecs.hpp"
#include "opencv2/imgproc.hpp"
#include "opencv2/videoio.hpp"

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

namespace {

// Each frame decoded, scaled to the first one's width and topped with its
// caption.
absl::StatusOr<std::vector<cv::Mat>> CaptionedTiles(const std::vector<std::string>& frames,
                                                    const std::vector<std::string>& captions) {
  if (frames.empty()) return absl::InvalidArgumentError("frames: none");
  if (captions.size() != frames.size()) {
    return absl::InvalidArgumentError("captions: one per frame needed");
  }
  constexpr int kCaptionPx = 36;
  std::vector<cv::Mat> tiles;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const std::vector<std::uint8_t> bytes(frames[i].begin(), frames[i].end());
    cv::Mat image = cv::imdecode(bytes, cv::IMREAD_COLOR);
    if (image.empty()) {
      return absl::InvalidArgumentError("frames[" + std::to_string(i) + "]: not an image");
    }
    if (!tiles.empty() && image.cols != tiles.front().cols) {
      const double scale = static_cast<double>(tiles.front().cols) / image.cols;
      cv::resize(image, image, cv::Size(), scale, scale, cv::INTER_AREA);
    }
    cv::Mat tile(image.rows + kCaptionPx, image.cols, CV_8UC3, cv::Scalar(255, 255, 255));
    image.copyTo(tile(cv::Rect(0, kCaptionPx, image.cols, image.rows)));
    cv::putText(tile, captions[i], cv::Point(8, kCaptionPx - 10), cv::FONT_HERSHEY_SIMPLEX, 0.9,
                cv::Scalar(0, 0, 0), 2, cv::LINE_AA);
    tiles.push_back(std::move(tile));
  }
  return tiles;
}

}  // namespace

absl::StatusOr<std::string> MontagePng(const std::vector<std::string>& frames,
                                       const std::vector<std::string>& captions, int columns) {
  if (columns < 1) return absl::InvalidArgumentError("columns: must be >= 1");
  OAIPP_ASSIGN_OR_RETURN(std::vector<cv::Mat> tiles, CaptionedTiles(frames, captions));
  const int cols = std::min<int>(columns, static_cast<int>(tiles.size()));
  const int rows = (static_cast<int>(tiles.size()) + cols - 1) / cols;
  int tile_h = 0;
  for (const cv::Mat& t : tiles) tile_h = std::max(tile_h, t.rows);
  const int tile_w = tiles.front().cols;
  cv::Mat sheet(rows * tile_h, cols * tile_w, CV_8UC3, cv::Scalar(255, 255, 255));
  for (std::size_t i = 0; i < tiles.size(); ++i) {
    const int r = static_cast<int>(i) / cols, c = static_cast<int>(i) % cols;
    tiles[i].copyTo(sheet(cv::Rect(c * tile_w, r * tile_h, tiles[i].cols, tiles[i].rows)));
  }
  std::vector<std::uint8_t> png;
  if (!cv::imencode(".png", sheet, png)) return absl::InternalError("montage: PNG encoding failed");
  return std::string(png.begin(), png.end());
}

absl::Status WriteVideo(const std::vector<std::string>& frames,
                        const std::vector<std::string>& captions, double fps,
                        const std::string& path) {
  if (!(fps > 0) || !std::isfinite(fps)) {
    return absl::InvalidArgumentError("fps: must be > 0 and finite");
  }
  OAIPP_ASSIGN_OR_RETURN(std::vector<cv::Mat> tiles, CaptionedTiles(frames, captions));
  const cv::Size size = tiles.front().size();
  cv::VideoWriter writer(path, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                         fps, size, /*isColor=*/true);
  if (!writer.isOpened()) {
    return absl::InternalError("video: cannot write '" + path + "'");
  }
  for (cv::Mat& tile : tiles) {
    if (tile.size() != size) cv::resize(tile, tile, size, 0, 0, cv::INTER_AREA);
    writer.write(tile);
  }
  writer.release();
  return absl::OkStatus();
}

}  // namespace oaipp::client
