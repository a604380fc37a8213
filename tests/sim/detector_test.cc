// The simulated detector's statistics against its configured probabilities
// over many seeded draws.
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"
#include "sim/scenario.h"
#include "sim/simulation.h"

namespace oaipp::sim {
namespace {

// One person at the field centre, no obstacles, no false positives unless
// asked for.
Simulation OnePerson(double fp_rate) {
  auto s = ParseScenario(
      absl::StrCat(
          R"({"targets": [{"x_min_m": -0.375, "x_max_m": 0.375, "y_min_m": -1, "y_max_m": 1}],)",
          R"("detector": {"fp_per_image_at_10m": )", fp_rate, "}}"),
      "test");
  EXPECT_TRUE(s.ok()) << s.status();
  auto sim = Simulation::Create(*s);
  EXPECT_TRUE(sim.ok()) << sim.status();
  return std::move(sim).value();
}

// Counts boxes that contain the image centre (the person under the camera).
double DetectionRate(const Simulation& sim, double altitude_m, int draws, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  int hits = 0;
  for (int i = 0; i < draws; ++i) {
    for (const PixelBox& b : sim.Detect(Vec3(0, 0, altitude_m), rng)) {
      if (b.x_min_px <= 240 && b.x_max_px >= 240 && b.y_min_px <= 320 && b.y_max_px >= 320) {
        ++hits;
        break;
      }
    }
  }
  return static_cast<double>(hits) / draws;
}

TEST(DetectorTest, DetectionFrequencyMatchesTheConfiguredCurve) {
  const Simulation sim = OnePerson(0.0);
  constexpr int kDraws = 20000;
  for (double h : {5.0, 10.0, 20.0, 25.0}) {
    // p(h) = 0.95 exp(-((h - 10) / 7)^2 / 2), computed here independently.
    const double p = 0.95 * std::exp(-0.5 * std::pow((h - 10.0) / 7.0, 2));
    const double sigma = std::sqrt(p * (1 - p) / kDraws);
    EXPECT_NEAR(DetectionRate(sim, h, kDraws, 7), p, 4 * sigma + 1e-9) << "h = " << h;
  }
}

TEST(DetectorTest, FalsePositivesArePoissonWithTheConfiguredMean) {
  // No target in view from far away: every box is a false positive.
  const Simulation sim = OnePerson(0.5);
  std::mt19937_64 rng(11);
  constexpr int kDraws = 20000;
  for (double h : {10.0, 20.0}) {
    double sum = 0, sum2 = 0;
    for (int i = 0; i < kDraws; ++i) {
      const double n = static_cast<double>(sim.Detect(Vec3(12, 12, h), rng).size());
      sum += n;
      sum2 += n * n;
    }
    const double mean = sum / kDraws, var = sum2 / kDraws - mean * mean;
    const double expected = 0.5 * (h / 10) * (h / 10);
    EXPECT_NEAR(mean, expected, 4 * std::sqrt(expected / kDraws)) << "h = " << h;
    EXPECT_NEAR(var, expected, 0.1 * expected) << "Poisson: variance = mean";
  }
}

TEST(DetectorTest, SameSeedSameDetections) {
  const Simulation sim = OnePerson(1.0);
  std::mt19937_64 a(3), b(3);
  for (int i = 0; i < 50; ++i) {
    const auto x = sim.Detect(Vec3(0, 0, 12), a), y = sim.Detect(Vec3(0, 0, 12), b);
    ASSERT_EQ(x.size(), y.size());
    for (std::size_t k = 0; k < x.size(); ++k) EXPECT_EQ(x[k].x_min_px, y[k].x_min_px);
  }
}

// The tally of sightings: the person under the camera is in view every
// time and reported as often as the configured p(h) says; a camera whose
// footprint misses the person counts nothing; counting leaves the random
// stream, and so the boxes, as they were.
TEST(DetectorTest, SightingsCountViewsAndDetections) {
  const Simulation sim = OnePerson(0.0);
  std::mt19937_64 counted(5), plain(5);
  std::vector<TargetSightings> tally;
  constexpr int kDraws = 20000;
  int boxes = 0;
  for (int i = 0; i < kDraws; ++i) {
    const auto x = sim.Detect(Vec3(0, 0, 14), counted, &tally);
    const auto y = sim.Detect(Vec3(0, 0, 14), plain);
    ASSERT_EQ(x.size(), y.size());
    for (std::size_t k = 0; k < x.size(); ++k) EXPECT_EQ(x[k].x_min_px, y[k].x_min_px);
    boxes += static_cast<int>(x.size());  // no false positives: each box is the person
  }
  ASSERT_EQ(tally.size(), 1u);
  EXPECT_EQ(tally[0].in_view, kDraws);
  EXPECT_EQ(tally[0].detected, boxes);
  const double p = 0.95 * std::exp(-0.5 * std::pow(4.0 / 7.0, 2));  // p(14 m)
  EXPECT_NEAR(static_cast<double>(tally[0].detected) / kDraws, p,
              4 * std::sqrt(p * (1 - p) / kDraws));
  // 5 m up at x = 12: the footprint is about 4 x 6 m, the person at x = 0.
  std::vector<TargetSightings> away;
  for (int i = 0; i < 100; ++i) (void)sim.Detect(Vec3(12, 0, 5), counted, &away);
  ASSERT_EQ(away.size(), 1u);
  EXPECT_EQ(away[0].in_view, 0);
  EXPECT_EQ(away[0].detected, 0);
}

// The false-positive rate a mission is told (FalsePositivesPerCell) is the
// share of cells in view over empty ground that the simulated detector
// labels as a person, at low, middle and high altitude alike, to within
// what it leaves out. The
// defaults' value, 0.3 x 2 x (1 + 2 / 0.75) x 0.5625 / (8.2843 x 11.547), is
// computed here independently.
TEST(DetectorTest, FalsePositivesPerCellMatchLabelledEmptyGround) {
  const Simulation defaults = OnePerson(0.3);
  EXPECT_NEAR(FalsePositivesPerCell(DetectorParams{}, defaults.config().camera, 0.75),
              0.012936641077651672, 1e-12);
  // Confidences are uniform on [0.5, 1]: a threshold of 0.75 keeps half.
  DetectorParams confident;
  confident.min_confidence = 0.75;
  EXPECT_NEAR(FalsePositivesPerCell(confident, defaults.config().camera, 0.75),
              0.006468320538825836, 1e-12);
  const Simulation sim = OnePerson(1.0);
  DetectorParams params;
  params.fp_per_image_at_10m = 1.0;
  const double q = FalsePositivesPerCell(params, sim.config().camera, 0.75);
  std::mt19937_64 rng(13);
  for (double h : {6.0, 10.0, 14.0}) {
    // Over (7.5-8.25, 6-6.75): the person at the origin stays out of the
    // footprint (at most 11.6 x 16.2 m at 14 m), the footprint inside the field.
    double labelled = 0, in_view = 0, boxes = 0;
    std::uniform_real_distribution<double> within_a_cell(0.0, 0.75);
    for (int i = 0; i < 4000; ++i) {
      // Moved within a cell each time: how many cell centres a footprint
      // holds depends on where its edges fall.
      const Vec3 camera(7.5 + within_a_cell(rng), 6.0 + within_a_cell(rng), h);
      const std::vector<PixelBox> detections = sim.Detect(camera, rng);
      boxes += static_cast<double>(detections.size());
      absl::StatusOr<CellLabels> labels = sim.Labels(camera, detections);
      ASSERT_TRUE(labels.ok()) << labels.status();
      in_view += static_cast<double>(labels->cells.size());
      for (double l : labels->labels) labelled += l;
    }
    ASSERT_GT(boxes, 1000);
    // The count of boxes is Poisson; a whole box covers 6 to 8 cells. The rate
    // leaves out two things that only lower the share: a box at the image's
    // edge overlaps some cells whose centres are out of view, and boxes may
    // overlap each other. Together 4-6 % here (1 box an image at 10 m).
    const double rate = labelled / in_view, four_se = 4 * q / std::sqrt(boxes);
    EXPECT_LT(rate, q + four_se) << "h = " << h;
    EXPECT_GT(rate, 0.92 * q - four_se) << "h = " << h;
  }
}

// A sure detector over each E1 person, camera 10 m above it: the boxes,
// projected back through the server's rule, mark exactly the cells the
// ground truth marks, 48 in all (docs/method.md), so a map equal to those labels
// has RSE 0.
TEST(DetectorTest, SureDetectionsOfE1PeopleMarkTheTruthCells) {
  auto scenario = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e1.json");
  ASSERT_TRUE(scenario.ok()) << scenario.status();
  scenario->mutable_detector()->set_p_max(1.0);
  scenario->mutable_detector()->set_fp_per_image_at_10m(0.0);
  auto sim = Simulation::Create(*scenario);
  ASSERT_TRUE(sim.ok()) << sim.status();
  ASSERT_EQ(sim->num_targets(), 7);
  std::mt19937_64 rng(1);
  std::set<int> ones, observed;
  for (const auto& person : scenario->targets()) {
    // Off-centre so that box edges fall between pixel centres of cells.
    const Vec3 camera(0.5 * (person.x_min_m() + person.x_max_m()) + 0.3,
                      0.5 * (person.y_min_m() + person.y_max_m()) - 0.2, 10.0);
    const std::vector<PixelBox> boxes = sim->Detect(camera, rng);
    ASSERT_FALSE(boxes.empty());
    auto labels = sim->Labels(camera, boxes);
    ASSERT_TRUE(labels.ok()) << labels.status();
    for (std::size_t i = 0; i < labels->cells.size(); ++i) {
      observed.insert(labels->cells[i]);
      if (labels->labels[i] == 1.0) ones.insert(labels->cells[i]);
    }
  }
  EXPECT_EQ(ones.size(), 48u);
  std::vector<double> map(1600, 0.0);
  for (int c : ones) map[static_cast<std::size_t>(c)] = 1.0;
  EXPECT_NEAR(sim->Rse(map), 0.0, 1e-12);
  EXPECT_EQ(sim->TargetsFound(map), 7);
  EXPECT_GT(observed.size(), 500u);
  // A map that is 0.6 on p3's rectangle only finds p3 (ids from e1.json).
  const auto& p3 = scenario->targets(2);
  std::vector<double> one(1600, 0.0);
  for (int c : ones) {
    const int col = c % 40, row = c / 40;  // 0.75 m cells from (-15, -15)
    const double x = -15 + 0.75 * (col + 0.5), y = -15 + 0.75 * (row + 0.5);
    if (x > p3.x_min_m() - 0.75 && x < p3.x_max_m() + 0.75 && y > p3.y_min_m() - 0.75 &&
        y < p3.y_max_m() + 0.75) {
      one[static_cast<std::size_t>(c)] = 0.6;
    }
  }
  EXPECT_EQ(sim->TargetIds(), (std::vector<std::string>{"p1", "p2", "p3", "p4", "p5", "p6", "p7"}));
  EXPECT_EQ(sim->FoundEach(one),
            (std::vector<bool>{false, false, true, false, false, false, false}));
  // The highest mean on each person's cells, which FoundEach compares with
  // 0.5.
  EXPECT_EQ(sim->TargetMeans(one), (std::vector<double>{0, 0, 0.6, 0, 0, 0, 0}));
  // The highest of a person's cells counts, whichever it is, and a NaN cell
  // is left out: p3's cells (the 0.75 m squares its rectangle overlaps) at
  // NaN, 0.7, 0.4, 0.2, ...
  std::vector<int> p3_cells;
  for (int c = 0; c < 1600; ++c) {
    const double x0 = -15 + 0.75 * (c % 40), y0 = -15 + 0.75 * (c / 40);
    if (x0 < p3.x_max_m() && x0 + 0.75 > p3.x_min_m() && y0 < p3.y_max_m() &&
        y0 + 0.75 > p3.y_min_m()) {
      p3_cells.push_back(c);
    }
  }
  ASSERT_GE(p3_cells.size(), 3u);
  std::vector<double> mixed(1600, 0.0);
  for (std::size_t k = 0; k < p3_cells.size(); ++k) {
    mixed[static_cast<std::size_t>(p3_cells[k])] = 0.1 * static_cast<double>(k % 3 + 2);
  }
  mixed[static_cast<std::size_t>(p3_cells[1])] = 0.7;
  mixed[static_cast<std::size_t>(p3_cells[0])] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(sim->TargetMeans(mixed)[2], 0.7);
  mixed[static_cast<std::size_t>(p3_cells[1])] = 0.45;  // now no cell passes 0.5
  EXPECT_EQ(sim->TargetMeans(mixed)[2], 0.45);
  EXPECT_FALSE(sim->FoundEach(mixed)[2]);
  // A map too short to reach any person has none.
  const std::vector<double> none = sim->TargetMeans({});
  ASSERT_EQ(none.size(), 7u);
  for (double m : none) EXPECT_EQ(m, -std::numeric_limits<double>::infinity());
}

// A perfect detector's labels: the visible footprint, 1 exactly on the cells
// whose square overlaps a person's rectangle with positive area (checked by
// brute force over the 0.75 m cells from (-15, -15)).
TEST(DetectorTest, TruthLabelsMarkTheCellsThePeopleCover) {
  auto scenario = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e1.json");
  ASSERT_TRUE(scenario.ok()) << scenario.status();
  auto sim = Simulation::Create(*scenario);
  ASSERT_TRUE(sim.ok()) << sim.status();
  const auto covered = [&](int cell) {
    const double x0 = -15 + 0.75 * (cell % 40), y0 = -15 + 0.75 * (cell / 40);
    for (const auto& t : scenario->targets()) {
      if (x0 < t.x_max_m() && x0 + 0.75 > t.x_min_m() && y0 < t.y_max_m() &&
          y0 + 0.75 > t.y_min_m()) {
        return true;
      }
    }
    return false;
  };
  int ones = 0;
  for (const Vec3& camera : {Vec3(8.3, -11.2, 10), Vec3(-6, -6, 14), Vec3(0, 8, 20)}) {
    const CellLabels labels = sim->TruthLabels(camera);
    ASSERT_FALSE(labels.cells.empty());
    ASSERT_EQ(labels.cells.size(), labels.labels.size());
    for (std::size_t i = 0; i < labels.cells.size(); ++i) {
      EXPECT_EQ(labels.labels[i], covered(labels.cells[i]) ? 1.0 : 0.0) << labels.cells[i];
      ones += labels.labels[i] == 1.0;
    }
    // The same cells a detector's labels cover from there.
    auto detected = sim->Labels(camera, {});
    ASSERT_TRUE(detected.ok());
    EXPECT_EQ(detected->cells, labels.cells);
  }
  EXPECT_GT(ones, 8);
}

}  // namespace
}  // namespace oaipp::sim
