#include "core/mapping/camera.h"

#include <cmath>
#include <random>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/mapping/fake_line_of_sight.h"
#include "tests/core/mapping/paper_grid.h"

namespace oaipp {
namespace {

using ::oaipp::testing::PaperGrid;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

TEST(SensorNoiseTest, MatchesReference) {
  const SensorNoise noise;  // A = 1, B = 0.05
  EXPECT_NEAR(noise.Variance(2), 0.095163, 5e-7);
  EXPECT_NEAR(noise.Variance(10), 0.393469, 5e-7);
  EXPECT_NEAR(noise.Variance(26), 0.727468, 5e-7);
  SensorNoise flat;
  flat.b_per_m = 0;
  EXPECT_THAT(flat.Validate().message(), HasSubstr("b_per_m"));
}

TEST(DownwardCameraTest, FootprintSizesMatchReference) {
  const DownwardCamera camera;
  EXPECT_NEAR(camera.FootprintSize(10).x(), 8.284271, 5e-7);
  EXPECT_NEAR(camera.FootprintSize(10).y(), 11.547005, 5e-7);
  EXPECT_NEAR(camera.FootprintSize(26).x(), 21.539105, 5e-7);
  EXPECT_NEAR(camera.FootprintSize(26).y(), 30.022214, 5e-7);
  EXPECT_EQ(camera.FootprintSize(-1), Vec2::Zero());
  EXPECT_THAT(DownwardCamera{.fov_x_deg = 180}.Validate().message(), HasSubstr("fov_x_deg"));
  // A field of view of 3e-307 deg once passed and made an infinite focal
  // length (found by fuzz/fuzz_requests).
  EXPECT_THAT(DownwardCamera{.fov_y_deg = 3.3e-307}.Validate().message(),
              HasSubstr("fov_y_deg: must be in [0.1, 180)"));
  EXPECT_TRUE(DownwardCamera{.fov_x_deg = kMinFovDeg}.Validate().ok());
}

TEST(DownwardCameraTest, FootprintCellsAtTheFieldCentre) {
  const FieldGrid grid = PaperGrid();
  const DownwardCamera camera;
  // At 10 m the footprint is +-4.142 m along x and +-5.774 m along y: the
  // centres +-0.375 .. +-4.125 (12 columns) and +-0.375 .. +-5.625 (16 rows).
  const std::vector<int> cells = camera.FootprintCells(grid, Vec3(0, 0, 10));
  EXPECT_EQ(cells.size(), 12u * 16u);
  EXPECT_EQ(cells.front(), grid.Index(20 - 8, 20 - 6));
  EXPECT_EQ(cells.back(), grid.Index(20 + 7, 20 + 5));
  // At 26 m it spills over the field (30.02 m along y): clipped to 40 rows.
  EXPECT_EQ(camera.FootprintCells(grid, Vec3(0, 0, 26)).size(), 28u * 40u);
  // Yawed by 90 degrees the sides swap.
  EXPECT_EQ(camera.FootprintCells(grid, Vec3(0, 0, 10), kPi / 2).size(), 16u * 12u);
  EXPECT_TRUE(camera.FootprintCells(grid, Vec3(0, 0, 0)).empty());
  EXPECT_TRUE(camera.FootprintCells(grid, Vec3(0, NAN, 5)).empty());
}

TEST(DownwardCameraTest, WallHidesTheCellsBehindIt) {
  // Seen from above, camera C at (0, 0, 10), an infinitely tall wall at x = 2:
  //
  //        |####
  //    C   |####   cells with centre x > 2 are hidden
  //        |####
  //   -----+----> x
  //        2
  const FieldGrid grid = PaperGrid();
  const DownwardCamera camera;
  const testing::WallAtX wall(2.0);
  const Vec3 p_WC(0, 0, 10);
  const std::vector<int> all = camera.FootprintCells(grid, p_WC);
  const std::vector<int> seen = camera.VisibleFootprintCells(grid, p_WC, &wall);
  EXPECT_EQ(camera.VisibleFootprintCells(grid, p_WC, nullptr), all);
  std::vector<int> expected;
  for (int c : all) {
    if (grid.CellCentreXY(c).x() < 2.0) expected.push_back(c);
  }
  EXPECT_EQ(seen, expected);
  EXPECT_EQ(seen.size(), 9u * 16u);  // centres -4.125 .. 1.875
}

TEST(LabelsToObservationsTest, UsesAltitudeVarianceAndValidates) {
  const FieldGrid grid = PaperGrid();
  const std::vector<int> cells = {4, 5};
  const std::vector<double> labels = {1.0, 0.0};
  auto obs = LabelsToObservations(grid, SensorNoise{}, 10.0, cells, labels);
  ASSERT_TRUE(obs.ok());
  ASSERT_EQ(obs->size(), 2u);
  EXPECT_EQ((*obs)[0].cell, 4);
  EXPECT_EQ((*obs)[0].value, 1.0);
  EXPECT_NEAR((*obs)[1].variance, 0.393469, 5e-7);

  const std::vector<double> bad_label = {1.0, 1.5};
  EXPECT_THAT(LabelsToObservations(grid, {}, 10, cells, bad_label).status().message(),
              HasSubstr("labels[1]"));
  EXPECT_THAT(LabelsToObservations(grid, {}, 0, cells, labels).status().message(),
              HasSubstr("altitude_m"));
  const std::vector<double> short_labels = {1.0};
  EXPECT_THAT(LabelsToObservations(grid, {}, 10, cells, short_labels).status().message(),
              HasSubstr("labels"));
  const std::vector<int> bad_cells = {4, 1600};
  EXPECT_THAT(LabelsToObservations(grid, {}, 10, bad_cells, labels).status().message(),
              HasSubstr("cells[1]"));

  const std::vector<CellObservation> predicted = PredictedObservations({}, 26, cells);
  ASSERT_EQ(predicted.size(), 2u);
  EXPECT_NEAR(predicted[1].variance, 0.727468, 5e-7);
  EXPECT_EQ(predicted[1].cell, 5);
}

// A detector with a false-positive rate: a detection and a miss get the
// variances of their likelihood ratios (p(10 m) = 0.95, q = 0.01:
// 1 / (2 ln 95) and 1 / (2 ln(0.99 / 0.05)), computed independently); a
// planned shot gets the miss's.
TEST(LabelsToObservationsTest, DetectionsAndMissesGetTheirOwnVarianceWithFalsePositives) {
  const FieldGrid grid = PaperGrid();
  SensorNoise noise;
  noise.detector = DetectorAccuracy{.false_positive_rate = 0.01};
  const std::vector<int> cells = {4, 5, 6};
  const std::vector<double> labels = {1.0, 0.0, 1.0};
  auto obs = LabelsToObservations(grid, noise, 10.0, cells, labels);
  ASSERT_TRUE(obs.ok()) << obs.status();
  ASSERT_EQ(obs->size(), 3u);
  EXPECT_NEAR((*obs)[0].variance, 0.1097965562, 1e-10);
  EXPECT_NEAR((*obs)[1].variance, 0.1674659292, 1e-10);
  EXPECT_EQ((*obs)[2].variance, (*obs)[0].variance);
  EXPECT_EQ((*obs)[1].value, 0.0);
  const std::vector<CellObservation> predicted = PredictedObservations(noise, 10.0, cells);
  ASSERT_EQ(predicted.size(), 3u);
  EXPECT_EQ(predicted[0].variance, (*obs)[1].variance);
}

}  // namespace
}  // namespace oaipp
