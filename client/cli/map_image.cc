#include "client/cli/map_image.h"

#include <algorithm>
#include <cmath>

#include "api/ground_outlines.h"
#include "core/common/status_macros.h"
#include "opencv2/imgcodecs.hpp"
#include "opencv2/imgproc.hpp"
#include "opencv2/videoio.hpp"
#include "render/map_render.h"

namespace oaipp::client {

absl::StatusOr<std::string> RenderMissionPng(const v1::GetMapResponse& map,
                                             const sim::Simulation& simulation,
                                             const std::vector<FlownPath>& paths,
                                             const std::string& mission_name,
                                             double mission_time_s) {
  const int nx = map.nx(), ny = map.ny();
  if (nx <= 0 || ny <= 0 || map.mean_size() != nx * ny || map.variance_size() != nx * ny) {
    return absl::InvalidArgumentError("map: needs its cells (GetMap with include_cells)");
  }
  const render::MapGrid grid{.nx = nx,
                             .ny = ny,
                             .resolution_m = map.resolution_m(),
                             .x_min_m = map.x_min_m(),
                             .y_min_m = map.y_min_m()};
  render::MapLayers layers;
  layers.mean.assign(map.mean().begin(), map.mean().end());
  layers.std_dev.reserve(static_cast<std::size_t>(map.variance_size()));
  for (double v : map.variance()) layers.std_dev.push_back(std::sqrt(std::max(0.0, v)));
  std::vector<Obstacle> obstacles;
  for (const auto& [id, o] : simulation.environment().obstacles()) obstacles.push_back(o);
  render::Overlay overlay(api::GroundOutlinesOf(simulation.config(), obstacles));
  overlay.targets = simulation.TargetRectangles();
  const auto ground = [](const std::vector<Vec3>& points_W) {
    std::vector<Vec2> xy;
    xy.reserve(points_W.size());
    for (const Vec3& p : points_W) xy.push_back(p.head<2>());
    return xy;
  };
  if (paths.size() == 1 && paths.front().uav_id.empty()) {
    overlay.path = ground(paths.front().points_W);
    overlay.path_label = "flown path";
  } else {
    for (const FlownPath& path : paths) {
      overlay.team_paths.push_back({.label = path.uav_id, .points = ground(path.points_W)});
    }
  }
  return render::RenderMapPng(
      grid, layers, overlay,
      {.mission = mission_name, .mission_time_s = mission_time_s, .trace = map.trace()});
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
