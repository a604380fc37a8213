#include "core/mapping/detection_projection.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <random>
#include <vector>

#include "core/mapping/camera.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "opencv2/calib3d.hpp"
#include "opencv2/core.hpp"
#include "tests/core/mapping/fake_line_of_sight.h"
#include "tests/core/mapping/paper_grid.h"

namespace oaipp {
namespace {

using ::oaipp::testing::PaperGrid;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

CameraIntrinsics Fov640x480() {
  auto k = IntrinsicsForFov(640, 480);
  EXPECT_TRUE(k.ok()) << k.status();
  return *k;
}

CameraIntrinsics Distorted() {
  CameraIntrinsics k = Fov640x480();
  k.k1 = -0.12;
  k.k2 = 0.03;
  k.p1 = 0.001;
  k.p2 = -0.0007;
  k.k3 = -0.004;
  return k;
}

// World -> pixels with OpenCV, the frame written out from the header's
// convention (rows of R_CW are the camera axes in W), independently of
// RotationWorldFromCamera.
std::vector<cv::Point2d> Project(const std::vector<Vec3>& points_W, const CameraIntrinsics& k,
                                 const CameraPose& pose) {
  const double c = std::cos(pose.yaw_rad), s = std::sin(pose.yaw_rad);
  const cv::Matx33d r_CW(c, s, 0,    // x_C = Rz x_W
                         s, -c, 0,   // y_C = Rz (-y_W)
                         0, 0, -1);  // z_C = -z_W
  const cv::Vec3d p(pose.p_WC.x(), pose.p_WC.y(), pose.p_WC.z());
  const cv::Vec3d t = -(r_CW * p);
  cv::Vec3d rvec;
  cv::Rodrigues(r_CW, rvec);
  std::vector<cv::Point3d> object;
  for (const Vec3& q : points_W) object.emplace_back(q.x(), q.y(), q.z());
  std::vector<cv::Point2d> pixels;
  const cv::Matx33d camera(k.fx_px, 0, k.cx_px, 0, k.fy_px, k.cy_px, 0, 0, 1);
  cv::projectPoints(object, rvec, t, camera, cv::Vec<double, 5>(k.k1, k.k2, k.p1, k.p2, k.k3),
                    pixels);
  return pixels;
}

TEST(IntrinsicsForFovTest, FocalLengthsGiveTheFieldOfView) {
  const CameraIntrinsics k = Fov640x480();
  EXPECT_NEAR(k.fx_px, 320.0 / std::tan(DegToRad(22.5)), 1e-9);
  EXPECT_NEAR(k.fy_px, 240.0 / std::tan(DegToRad(30.0)), 1e-9);
  EXPECT_EQ(k.cx_px, 320.0);
  EXPECT_EQ(k.cy_px, 240.0);
  EXPECT_TRUE(k.Validate().ok());
  // The image corner (640, 0) at 10 m is the footprint corner (+4.142, +5.774).
  auto corner =
      GroundPolygon(k, {.p_WC = Vec3(0, 0, 10)},
                    {.x_min_px = 320, .y_min_px = 0, .x_max_px = 640, .y_max_px = 240}, 1);
  ASSERT_TRUE(corner.ok());
  EXPECT_TRUE((*corner)[1].isApprox(Vec2(8.284271 / 2, 11.547005 / 2), 1e-6));
  EXPECT_THAT(IntrinsicsForFov(0, 480).status().message(), HasSubstr("width_px"));
  EXPECT_THAT(IntrinsicsForFov(640, 480, 45, 180).status().message(), HasSubstr("fov_y_deg"));
}

// The image footprint of the FoV-matched camera is DownwardCamera's
// rectangle, at any altitude, position and yaw.
TEST(ImageFootprintTest, MatchesDownwardCameraFootprint) {
  const FieldGrid grid = PaperGrid();
  const DownwardCamera camera;
  const CameraIntrinsics k = Fov640x480();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> pos(-14, 14), alt(2, 26), yaw(-3.2, 3.2);
  for (int trial = 0; trial < 40; ++trial) {
    const CameraPose pose{.p_WC = Vec3{pos(rng), pos(rng), alt(rng)},
                          .yaw_rad = trial < 10 ? 0.0 : yaw(rng)};
    auto cells = ImageFootprintCells(grid, k, pose, nullptr);
    ASSERT_TRUE(cells.ok());
    ASSERT_EQ(*cells, camera.FootprintCells(grid, pose.p_WC, pose.yaw_rad)) << "trial " << trial;
  }
}

// Ground rectangle -> cv::projectPoints -> pixel box -> DetectionCells gives
// back the cells the rectangle overlaps, the rule that rasterises ground
// truth (no distortion; yaw 0 and 90 deg keep world rectangles axis-aligned
// in the image).
TEST(DetectionCellsTest, GroundRectangleRoundTrip) {
  const FieldGrid grid = PaperGrid();
  const CameraIntrinsics k = Fov640x480();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> off(-2.5, 2.5), size(0.3, 3.0);
  for (int trial = 0; trial < 50; ++trial) {
    const CameraPose pose{.p_WC = Vec3{off(rng), off(rng), 12.0},
                          .yaw_rad = trial % 2 == 0 ? 0.0 : kPi / 2};
    const Vec2 centre = pose.p_WC.head<2>() + Vec2{off(rng), off(rng)};
    const Vec2 half{0.5 * size(rng), 0.5 * size(rng)};
    const std::vector<Vec3> corners = {{centre.x() - half.x(), centre.y() - half.y(), 0},
                                       {centre.x() + half.x(), centre.y() + half.y(), 0}};
    const std::vector<cv::Point2d> px = Project(corners, k, pose);
    const PixelBox box{.x_min_px = std::min(px[0].x, px[1].x),
                       .y_min_px = std::min(px[0].y, px[1].y),
                       .x_max_px = std::max(px[0].x, px[1].x),
                       .y_max_px = std::max(px[0].y, px[1].y),
                       .confidence = 0.9};
    auto cells = DetectionCells(grid, k, pose, {&box, 1}, 0.5, nullptr);
    ASSERT_TRUE(cells.ok()) << cells.status();
    ASSERT_EQ(*cells, grid.CellsOverlapping(centre - half, centre + half)) << "trial " << trial;
  }
}

// With distortion: the ground polygon of a box projects back onto the box's
// boundary; a cell whose projected centre falls in the box, or which has a
// point well inside the box, is detected; a detected cell has a point in the
// box (to within a pixel, the polygon following curved edges at 16 points);
// the 1-labels are the detected cells in the image footprint.
TEST(DetectionCellsTest, DistortedRoundTrip) {
  const FieldGrid grid = PaperGrid();
  const CameraIntrinsics k = Distorted();
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(0, 640), v(0, 480), yaw(-3, 3);
  int cells_checked = 0;
  for (int trial = 0; trial < 30; ++trial) {
    const CameraPose pose{.p_WC = Vec3(1.0, -2.0, 9.0), .yaw_rad = yaw(rng)};
    const double u0 = u(rng), u1 = u(rng), v0 = v(rng), v1 = v(rng);
    const PixelBox box{.x_min_px = std::min(u0, u1),
                       .y_min_px = std::min(v0, v1),
                       .x_max_px = std::max(u0, u1),
                       .y_max_px = std::max(v0, v1)};
    auto polygon = GroundPolygon(k, pose, box, 8);
    ASSERT_TRUE(polygon.ok());
    std::vector<Vec3> ground;
    for (const Vec2& g : *polygon) ground.emplace_back(g.x(), g.y(), 0.0);
    const std::vector<cv::Point2d> back = Project(ground, k, pose);
    for (std::size_t i = 0; i < back.size(); ++i) {
      const double to_edge =
          std::min({std::abs(back[i].x - box.x_min_px), std::abs(back[i].x - box.x_max_px),
                    std::abs(back[i].y - box.y_min_px), std::abs(back[i].y - box.y_max_px)});
      ASSERT_LT(to_edge, 1e-6) << "trial " << trial << " vertex " << i;
    }
    EXPECT_NEAR(back[0].x, box.x_min_px, 1e-6);
    EXPECT_NEAR(back[0].y, box.y_min_px, 1e-6);

    auto cells = DetectionCells(grid, k, pose, {&box, 1}, 0.0, nullptr);
    auto labels = DetectionsToLabels(grid, k, pose, {&box, 1}, 0.0, nullptr);
    auto footprint = ImageFootprintCells(grid, k, pose, nullptr);
    ASSERT_TRUE(cells.ok() && labels.ok() && footprint.ok());
    std::vector<int> labelled, expected;
    for (std::size_t i = 0; i < labels->cells.size(); ++i) {
      if (labels->labels[i] == 1.0) labelled.push_back(labels->cells[i]);
    }
    std::set_intersection(cells->begin(), cells->end(), footprint->begin(), footprint->end(),
                          std::back_inserter(expected));
    ASSERT_EQ(labelled, expected) << "trial " << trial;
    cells_checked += static_cast<int>(labelled.size());

    // Each cell near the box, sampled at 11 x 11 points of its square.
    const double r = grid.resolution_m();
    for (int cell = 0; cell < grid.num_cells(); ++cell) {
      const Vec2 c = grid.CellCentreXY(cell);
      if ((c - pose.p_WC.head<2>()).norm() > 9.0) continue;  // far outside the image
      std::vector<Vec3> samples = {{c.x(), c.y(), 0.0}};
      for (int i = 0; i <= 10; ++i) {
        for (int j = 0; j <= 10; ++j) {
          samples.emplace_back(c.x() + r * (i / 10.0 - 0.5), c.y() + r * (j / 10.0 - 0.5), 0.0);
        }
      }
      const std::vector<cv::Point2d> px = Project(samples, k, pose);
      const auto in_box = [&](const cv::Point2d& q, double margin) {
        return q.x >= box.x_min_px - margin && q.x <= box.x_max_px + margin &&
               q.y >= box.y_min_px - margin && q.y <= box.y_max_px + margin;
      };
      const bool detected = std::binary_search(cells->begin(), cells->end(), cell);
      if (in_box(px[0], 0.0) || std::any_of(px.begin(), px.end(), [&](const cv::Point2d& q) {
            return in_box(q, -1.0);
          })) {
        ASSERT_TRUE(detected) << "trial " << trial << " cell " << cell;
      }
      if (detected) {
        // Sampling can miss a sliver: allow one sample spacing plus a pixel.
        const double spacing_px = 0.1 * r * k.fx_px / pose.p_WC.z() * 1.5;
        ASSERT_TRUE(std::any_of(px.begin(), px.end(),
                                [&](const cv::Point2d& q) { return in_box(q, spacing_px + 1.0); }))
            << "trial " << trial << " cell " << cell;
      }
    }
  }
  EXPECT_GT(cells_checked, 200);
}

TEST(DetectionCellsTest, BoxAtImageCentreIsTheCellUnderTheCamera) {
  const FieldGrid grid = PaperGrid();
  const int under = grid.Index(22, 17);
  const Vec2 c = grid.CellCentreXY(under);
  for (const CameraIntrinsics& k : {Fov640x480(), Distorted()}) {
    for (double yaw : {0.0, 0.7, -2.5}) {
      const CameraPose pose{.p_WC = Vec3(c.x() + 0.1, c.y() - 0.05, 10.0), .yaw_rad = yaw};
      // +-15 px across and +-7 px down the image are +-0.19 m and +-0.17 m on
      // the ground here (0.26 m to a corner): from 0.11 m off the centre of
      // the cell under the camera the box stays inside that cell's square at
      // every yaw tried.
      const PixelBox box{.x_min_px = k.cx_px - 15,
                         .y_min_px = k.cy_px - 7,
                         .x_max_px = k.cx_px + 15,
                         .y_max_px = k.cy_px + 7};
      auto cells = DetectionCells(grid, k, pose, {&box, 1}, 0.0, nullptr);
      ASSERT_TRUE(cells.ok());
      EXPECT_THAT(*cells, ElementsAre(under)) << "yaw " << yaw;
    }
  }
}

TEST(DetectionCellsTest, OccludedDetectionsYieldNoCells) {
  const FieldGrid grid = PaperGrid();
  const CameraIntrinsics k = Fov640x480();
  const CameraPose pose{.p_WC = Vec3(0, 0, 10)};
  const PixelBox whole{.x_min_px = 0, .y_min_px = 0, .x_max_px = 640, .y_max_px = 480};
  const testing::BlockEverything roof;
  auto hidden = DetectionCells(grid, k, pose, {&whole, 1}, 0.0, &roof);
  ASSERT_TRUE(hidden.ok());
  EXPECT_TRUE(hidden->empty());
  auto labels = DetectionsToLabels(grid, k, pose, {&whole, 1}, 0.0, &roof);
  ASSERT_TRUE(labels.ok());
  EXPECT_TRUE(labels->cells.empty());

  // A wall at x = 2 m hides the right part of a detection straddling it.
  const testing::WallAtX wall(2.0);
  auto part = DetectionCells(grid, k, pose, {&whole, 1}, 0.0, &wall);
  auto all = DetectionCells(grid, k, pose, {&whole, 1}, 0.0, nullptr);
  ASSERT_TRUE(part.ok() && all.ok());
  EXPECT_EQ(all->size(), 12u * 16u);
  EXPECT_EQ(part->size(), 9u * 16u);
  for (int cell : *part) EXPECT_LT(grid.CellCentreXY(cell).x(), 2.0);
}

TEST(DetectionsToLabelsTest, OnesUnderConfidentBoxesZerosElsewhere) {
  const FieldGrid grid = PaperGrid();
  const CameraIntrinsics k = Fov640x480();
  const CameraPose pose{.p_WC = Vec3(0.2, -0.3, 10)};
  const std::vector<PixelBox> boxes = {
      {.x_min_px = 100, .y_min_px = 100, .x_max_px = 200, .y_max_px = 180, .confidence = 0.6},
      {.x_min_px = 400, .y_min_px = 300, .x_max_px = 500, .y_max_px = 400, .confidence = 0.01}};
  auto labels = DetectionsToLabels(grid, k, pose, boxes, 0.05, nullptr);
  ASSERT_TRUE(labels.ok());
  auto footprint = ImageFootprintCells(grid, k, pose, nullptr);
  ASSERT_TRUE(footprint.ok());
  EXPECT_EQ(labels->cells, *footprint);
  ASSERT_EQ(labels->labels.size(), labels->cells.size());
  auto detected = DetectionCells(grid, k, pose, boxes, 0.05, nullptr);
  ASSERT_TRUE(detected.ok());
  ASSERT_FALSE(detected->empty());
  for (std::size_t i = 0; i < labels->cells.size(); ++i) {
    const bool in_box = std::binary_search(detected->begin(), detected->end(), labels->cells[i]);
    EXPECT_EQ(labels->labels[i], in_box ? 1.0 : 0.0) << "cell " << labels->cells[i];
  }
  // The low-confidence box counts once the threshold drops.
  auto both = DetectionCells(grid, k, pose, boxes, 0.0, nullptr);
  ASSERT_TRUE(both.ok());
  EXPECT_GT(both->size(), detected->size());
}

TEST(DetectionProjectionTest, InvalidInputNamesTheField) {
  const FieldGrid grid = PaperGrid();
  const CameraPose pose{.p_WC = Vec3(0, 0, 10)};
  const PixelBox ok_box{.x_min_px = 10, .y_min_px = 10, .x_max_px = 20, .y_max_px = 20};
  auto with = [&](auto mutate) {
    CameraIntrinsics k = Fov640x480();
    mutate(k);
    return DetectionCells(grid, k, pose, {&ok_box, 1}, 0.0, nullptr).status();
  };
  EXPECT_THAT(with([](CameraIntrinsics& k) { k.fx_px = 0; }).message(),
              HasSubstr("intrinsics.fx_px"));
  EXPECT_THAT(with([](CameraIntrinsics& k) { k.fy_px = NAN; }).message(),
              HasSubstr("intrinsics.fy_px"));
  EXPECT_THAT(with([](CameraIntrinsics& k) { k.cy_px = INFINITY; }).message(),
              HasSubstr("intrinsics.cy_px"));
  EXPECT_THAT(with([](CameraIntrinsics& k) { k.height_px = 0; }).message(),
              HasSubstr("intrinsics.height_px"));
  EXPECT_THAT(with([](CameraIntrinsics& k) { k.k2 = NAN; }).message(), HasSubstr("intrinsics.k2"));

  const CameraIntrinsics k = Fov640x480();
  auto box_error = [&](PixelBox b) {
    const std::vector<PixelBox> boxes = {ok_box, b};
    const absl::Status s = DetectionCells(grid, k, pose, boxes, 0.0, nullptr).status();
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
    return std::string(s.message());
  };
  EXPECT_THAT(box_error({.x_min_px = 30, .y_min_px = 10, .x_max_px = 20, .y_max_px = 20}),
              HasSubstr("boxes[1].x_max_px"));
  EXPECT_THAT(box_error({.x_min_px = 10, .y_min_px = 10, .x_max_px = 20, .y_max_px = 10}),
              HasSubstr("boxes[1].y_max_px"));
  EXPECT_THAT(box_error({.x_min_px = 10, .y_min_px = 10, .x_max_px = 641, .y_max_px = 20}),
              HasSubstr("boxes[1].x_max_px"));
  EXPECT_THAT(box_error({.x_min_px = -1, .y_min_px = 10, .x_max_px = 20, .y_max_px = 20}),
              HasSubstr("boxes[1].x_min_px"));
  EXPECT_THAT(box_error({.x_min_px = 10, .y_min_px = NAN, .x_max_px = 20, .y_max_px = 20}),
              HasSubstr("boxes[1].y_min_px"));
  EXPECT_THAT(
      box_error({.x_min_px = 1, .y_min_px = 1, .x_max_px = 2, .y_max_px = 2, .confidence = 2}),
      HasSubstr("boxes[1].confidence"));

  auto low = DetectionCells(grid, k, {.p_WC = Vec3(0, 0, 0)}, {&ok_box, 1}, 0.0, nullptr);
  EXPECT_THAT(low.status().message(), HasSubstr("pose.p_WC.z"));
  auto nan_pose = ImageFootprintCells(grid, k, {.p_WC = Vec3(NAN, 0, 5)}, nullptr);
  EXPECT_THAT(nan_pose.status().message(), HasSubstr("pose.p_WC"));
  EXPECT_THAT(DetectionCells(grid, k, pose, {&ok_box, 1}, 1.5, nullptr).status().message(),
              HasSubstr("min_confidence"));
  EXPECT_THAT(GroundPolygon(k, pose, ok_box, 0).status().message(), HasSubstr("samples_per_edge"));
}

}  // namespace
}  // namespace oaipp
