// The SAREnv evaluator and baselines against numbers from outside the code:
// files NumPy wrote, cases worked out by hand, and the benchmark's published
// results for dataset 1's medium crop (data/LICENSE-SAREnv).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "client/sarenv/baselines.h"
#include "client/sarenv/dataset.h"
#include "client/sarenv/metrics.h"
#include "client/sarenv/npy.h"

namespace oaipp::sarenv {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

const std::string kData = OAIPP_SARENV_TEST_DATA;

std::string Bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// small_*.npy were written by NumPy 1.24 from
// np.array([[0.5, -1.25, 3.0], [1e-300, 2.5e10, 0.1]]).
void ExpectSmallValues(const Grid2D& g) {
  EXPECT_EQ(g.rows, 2);
  EXPECT_EQ(g.cols, 3);
  EXPECT_THAT(g.values, ElementsAre(0.5, -1.25, 3.0, 1e-300, 2.5e10, 0.1));
  EXPECT_EQ(g.At(1, 2), 0.1);
}

TEST(NpyTest, ReadsVersionOneWrittenByNumpy) {
  absl::StatusOr<Grid2D> g = ReadNpy(kData + "/small_v1.npy");
  ASSERT_TRUE(g.ok()) << g.status();
  ExpectSmallValues(*g);
}

TEST(NpyTest, ReadsVersionTwoWrittenByNumpy) {
  absl::StatusOr<Grid2D> g = ReadNpy(kData + "/small_v2.npy");
  ASSERT_TRUE(g.ok()) << g.status();
  ExpectSmallValues(*g);
}

TEST(NpyTest, WritesTheBytesNumpyWrites) {
  absl::StatusOr<Grid2D> g = ReadNpy(kData + "/small_v1.npy");
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_EQ(EncodeNpy(*g), Bytes(kData + "/small_v1.npy"));
  const std::string path = ::testing::TempDir() + "/sarenv_roundtrip.npy";
  ASSERT_TRUE(WriteNpy(path, *g).ok());
  absl::StatusOr<Grid2D> again = ReadNpy(path);
  ASSERT_TRUE(again.ok()) << again.status();
  ExpectSmallValues(*again);
}

void ExpectRefused(const absl::StatusOr<Grid2D>& g, const std::string& file,
                   const std::string& what) {
  ASSERT_FALSE(g.ok());
  EXPECT_EQ(g.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(g.status().message()), HasSubstr(file));
  EXPECT_THAT(std::string(g.status().message()), HasSubstr(what));
}

TEST(NpyTest, RefusesOtherDtypesOrdersAndShapes) {
  ExpectRefused(ReadNpy(kData + "/small_f4.npy"), "small_f4.npy", "'<f4'");
  ExpectRefused(ReadNpy(kData + "/small_fortran.npy"), "small_fortran.npy", "Fortran");
  ExpectRefused(ReadNpy(kData + "/small_1d.npy"), "small_1d.npy", "not 2-D");
}

TEST(NpyTest, RefusesTruncatedFilesAndBadMagic) {
  const std::string whole = Bytes(kData + "/small_v1.npy");
  const std::string cut = ::testing::TempDir() + "/sarenv_cut.npy";
  std::ofstream(cut, std::ios::binary) << whole.substr(0, whole.size() - 5);
  ExpectRefused(ReadNpy(cut), "sarenv_cut.npy", "truncated");
  ExpectRefused(ParseNpy(whole.substr(0, 40), "head.npy"), "head.npy", "truncated");
  ExpectRefused(ParseNpy("\x93NUMPZ" + whole.substr(6), "magic.npy"), "magic.npy", "magic");
  EXPECT_EQ(ReadNpy(kData + "/no_such.npy").status().code(), absl::StatusCode::kNotFound);
}

// 3 x 3 cells of 30 m on [0, 90]^2, values 1..9 row by row from the south.
SearchArea NineCells() {
  return {.name = "nine",
          .crs = "local",
          .heatmap = {.rows = 3, .cols = 3, .values = {1, 2, 3, 4, 5, 6, 7, 8, 9}},
          .bounds = {0, 0, 90, 90},
          .center_x_m = 45,
          .center_y_m = 45,
          .radius_m = 45,
          .meter_per_bin = 30};
}

TEST(MetricsTest, SensorRadiusIs80TimesTan22Point5) {
  // tan(22.5 deg) = sqrt(2) - 1.
  EXPECT_NEAR(DetectionRadius_m({}), 80 * (std::numbers::sqrt2 - 1), 1e-12);
}

TEST(MetricsTest, OnePositionSeesItsCellAndTheFourEdgeNeighbours) {
  // Edge neighbours' centres are 30 m away, corner ones 42.4 m: past 33.137 m.
  EXPECT_THAT(VisibleCells(NineCells(), DetectionRadius_m({}), {45, 45}),
              ElementsAre(1, 3, 4, 5, 7));
  // From 15 m east of the centre: the centre and east cells (15 m); the
  // cells north and south of them are sqrt(15^2 + 30^2) = 33.54 m away.
  EXPECT_THAT(VisibleCells(NineCells(), DetectionRadius_m({}), {60, 45}), ElementsAre(4, 5));
}

TEST(MetricsTest, SamplesAtOnePointScoreTheMapThere) {
  // A 1 mm path: two samples (its ends), both seeing values 2, 4, 5, 6, 8.
  const MapScores s = ScoreOnMap(NineCells(), {{{45, 45}, {45.001, 45}}});
  EXPECT_DOUBLE_EQ(s.likelihood, 25);
  EXPECT_NEAR(s.time_discounted, 25 * (1 + std::pow(0.999, 0.001)), 1e-12);
}

TEST(MetricsTest, TwoSamplesFifteenMetresApartAreDiscountedBy0999To15) {
  const MapScores s = ScoreOnMap(NineCells(), {{{45, 45}, {60, 45}}});
  EXPECT_DOUBLE_EQ(s.likelihood, 25);  // the second sample sees no new cell
  EXPECT_NEAR(s.time_discounted, 25 + 11 * std::pow(0.999, 15), 1e-12);
}

TEST(MetricsTest, DronesAreCountedOneAfterTheOther) {
  // The second drone's distances start where the first one's end (15 m).
  const Polyline path{{45, 45}, {60, 45}};
  const MapScores s = ScoreOnMap(NineCells(), {path, path});
  EXPECT_NEAR(s.time_discounted,
              25 + 11 * std::pow(0.999, 15) + 25 * std::pow(0.999, 15) + 11 * std::pow(0.999, 30),
              1e-12);
}

TEST(MetricsTest, SamplesAreAtMostFifteenMetresApart) {
  const std::vector<PointXY> p = SamplePath({{0, 0}, {100, 0}}, 15);
  ASSERT_EQ(p.size(), 8u);  // ceil(100 / 15) + 1
  EXPECT_DOUBLE_EQ(p[1].x_m, 100.0 / 7);
  EXPECT_DOUBLE_EQ(p.back().x_m, 100);
  EXPECT_TRUE(SamplePath({{5, 5}}, 15).empty());
}

TEST(MetricsTest, CutsAPathAtALengthAndABudgetPerDrone) {
  const Polyline l{{0, 0}, {10, 0}, {10, 10}};
  const Polyline cut = CutToLength(l, 15);
  ASSERT_EQ(cut.size(), 3u);
  EXPECT_DOUBLE_EQ(cut[2].y_m, 5);
  EXPECT_DOUBLE_EQ(PolylineLength_m(cut), 15);
  const std::vector<Polyline> two = CutToBudget({l, l}, 24);  // 12 m each
  EXPECT_DOUBLE_EQ(PolylineLength_m(two[0]), 12);
  EXPECT_DOUBLE_EQ(PolylineLength_m(two[1]), 12);
  const Polyline middle = Substring(l, 5, 12);  // (5, 0), (10, 0), (10, 2)
  ASSERT_EQ(middle.size(), 3u);
  EXPECT_DOUBLE_EQ(middle[0].x_m, 5);
  EXPECT_DOUBLE_EQ(middle[2].y_m, 2);
}

// Area of the regular 64-gon inscribed in a circle of radius r: GEOS's
// round buffer with 16 segments per quadrant.
double Polygon64(double r) { return 32 * r * r * std::sin(std::numbers::pi / 32); }

TEST(MetricsTest, APointsBufferIsACircleToThePolygonsError) {
  const double r = DetectionRadius_m({});
  absl::StatusOr<Coverage> c = BufferedCoverage({{{100, 100}, {100 + 1e-7, 100}}}, r, {});
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_NEAR(c->area_m2, Polygon64(r), 1e-6 * Polygon64(r));
  // The polygon falls short of pi r^2 by (pi / 32)^2 / 6 = 0.16 %.
  EXPECT_NEAR(c->area_m2 / (std::numbers::pi * r * r), 1, 2e-3);
}

TEST(MetricsTest, AStraightPathCoversTwoRadiiTimesItsLengthPlusACircle) {
  const double r = DetectionRadius_m({});
  const double length = 1000;
  absl::StatusOr<Coverage> c =
      BufferedCoverage({{{0, 0}, {length, 0}}}, r, {{500, 30}, {500, 34}, {-20, 0}, {1040, 0}});
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_NEAR(c->area_m2, 2 * r * length + Polygon64(r), 1e-9 * c->area_m2);
  EXPECT_NEAR(c->area_m2, 2 * r * length + std::numbers::pi * r * r, 1e-4 * c->area_m2);
  EXPECT_EQ(c->victims_inside, 2);  // (500, 30) and (-20, 0)
}

TEST(MetricsTest, OverlappingPathsCountTheirAreaOnce) {
  const double r = DetectionRadius_m({});
  const Polyline line{{0, 0}, {1000, 0}};
  absl::StatusOr<Coverage> one = BufferedCoverage({line}, r, {});
  absl::StatusOr<Coverage> twice = BufferedCoverage({line, line}, r, {});
  ASSERT_TRUE(one.ok() && twice.ok());
  EXPECT_NEAR(twice->area_m2, one->area_m2, 1e-9 * one->area_m2);
}

TEST(MetricsTest, VictimsComeFromCellsWithProbabilityOnly) {
  SearchArea a = NineCells();
  a.heatmap.values = {0, 0, 0, 0, 0, 0, 0, 0, 1};  // only the north-east cell
  const std::vector<PointXY> v = DrawVictims(a, 50, 7);
  ASSERT_EQ(v.size(), 50u);
  for (const PointXY& p : v) {
    EXPECT_GE(p.x_m, 60);
    EXPECT_LT(p.x_m, 90);
    EXPECT_GE(p.y_m, 60);
    EXPECT_LT(p.y_m, 90);
  }
  EXPECT_EQ(DrawVictims(a, 50, 7).front().x_m, v.front().x_m);
  EXPECT_NE(DrawVictims(a, 1, 8).front().x_m, v.front().x_m);
}

TEST(DatasetTest, CropsTheDiscAsTheBenchmarkDoes) {
  // A 10 x 10 map of ones, 30 m cells; a 60 m disc around (150, 150): the
  // square [90, 210]^2 is source cells 3..6, and the kept ones have
  // (col - 5)^2 + (row - 5)^2 <= 2^2: 11 of those 16.
  Dataset d;
  d.name = "synthetic";
  d.crs = "local";
  d.bounds = {0, 0, 300, 300};
  d.meter_per_bin = 30;
  d.heatmap = {.rows = 10, .cols = 10, .values = std::vector<double>(100, 1.0)};
  absl::StatusOr<SearchArea> a = CropToDisc(d, 150, 150, 60);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_EQ(a->heatmap.rows, 4);
  EXPECT_EQ(a->heatmap.cols, 4);
  double mass = 0;
  for (double v : a->heatmap.values) mass += v;
  EXPECT_EQ(mass, 11);
  EXPECT_EQ(a->heatmap.At(0, 0), 0);  // source (3, 3): 8 cells^2 away
  EXPECT_EQ(a->heatmap.At(0, 2), 1);  // source (3, 5)
  EXPECT_EQ(a->bounds.min_x_m, 90);
  EXPECT_EQ(a->bounds.max_y_m, 210);
}

TEST(DatasetTest, SizesOfAFlatTemperatePlace) {
  EXPECT_EQ(*SizeRadiusKm("flat", "temperate", "medium"), 1.8);
  EXPECT_EQ(*SizeRadiusKm("flat", "temperate", "small"), 0.6);
  EXPECT_EQ(*SizeRadiusKm("flat", "temperate", "large"), 3.2);
  EXPECT_FALSE(SizeRadiusKm("flat", "temperate", "huge").ok());
  EXPECT_FALSE(SizeRadiusKm("swamp", "temperate", "medium").ok());
}

TEST(DatasetTest, ProjectsDatasetOnesCentreToTheMiddleOfItsMap) {
  // Dataset 1's meta.json: centre (-2.704825, 51.117314), and bounds whose
  // middle is (520660.0171335154, 5662912.206616023) in EPSG:32630.
  absl::StatusOr<std::array<double, 2>> xy = ProjectLonLat(-2.704825, 51.117314, "EPSG:32630");
  ASSERT_TRUE(xy.ok()) << xy.status();
  EXPECT_NEAR((*xy)[0], 520660.0171335154, 1e-6);
  EXPECT_NEAR((*xy)[1], 5662912.206616023, 1e-6);
}

TEST(DatasetTest, LoadsAFolderAndNamesWhatIsMissing) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "sarenv_ds" / "7";
  std::filesystem::create_directories(dir);
  ASSERT_TRUE(WriteNpy((dir / "heatmap.npy").string(),
                       {.rows = 2, .cols = 2, .values = {0.1, 0.2, 0.3, 0.4}})
                  .ok());
  std::ofstream(dir / "meta.json") << R"({"center_point": [10.5, 55.0], "meter_per_bin": 30,
      "bounds": [0, 0, 60, 60], "climate": "temperate", "environment_type": "flat",
      "radius_km": 9.9, "crs": "EPSG:32632"})";
  absl::StatusOr<Dataset> d = LoadDataset(dir.string());
  ASSERT_TRUE(d.ok()) << d.status();
  EXPECT_EQ(d->name, "7");
  EXPECT_EQ(d->heatmap.At(1, 0), 0.3);
  EXPECT_EQ(d->bounds.max_x_m, 60);
  std::ofstream(dir / "meta.json") << R"({"center_point": [10.5, 55.0]})";
  absl::StatusOr<Dataset> bad = LoadDataset(dir.string());
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(bad.status().message()), HasSubstr("bounds"));
  std::ofstream(dir / "meta.json") << "{not json";
  EXPECT_EQ(LoadDataset(dir.string()).status().code(), absl::StatusCode::kInvalidArgument);
}

absl::StatusOr<SearchArea> DatasetOneMedium() {
  return ReadSearchArea(kData + "/dataset1_medium.npy", kData + "/dataset1_medium.json");
}

TEST(PublishedTest, TheCommittedCropIsDatasetOnesMediumDisc) {
  absl::StatusOr<SearchArea> a = DatasetOneMedium();
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_EQ(a->heatmap.rows, 120);
  EXPECT_EQ(a->heatmap.cols, 120);
  EXPECT_EQ(a->radius_m, 1800);
  double mass = 0;
  for (double v : a->heatmap.values) mass += v;
  EXPECT_NEAR(mass, 0.2807, 5e-5);  // the SAREnv README's figure
}

struct PublishedRow {
  Baseline baseline;
  int n;
  double likelihood, time_discounted, area_km2;
};

// SAREnv's results/comparative_metrics_results_n{1,2,5}_budget100000.csv,
// dataset 1, size medium, budget 100000 m: Likelihood Score,
// Time-Discounted Score, Area Covered (km²).
constexpr PublishedRow kPublished[] = {
    {Baseline::kSpiral, 1, 0.20317420338854836, 0.00815435967171108, 6.627888122020389},
    {Baseline::kSpiral, 2, 0.1965154852672919, 0.008186293057392123, 6.631366877143253},
    {Baseline::kSpiral, 5, 0.18888123435980742, 0.008191468628987314, 6.641881290759641},
    {Baseline::kConcentric, 1, 0.20440390931545602, 0.008375738218246172, 6.582219955700275},
    {Baseline::kConcentric, 2, 0.1950289823344325, 0.008380290385453544, 6.5901564215605495},
    {Baseline::kConcentric, 5, 0.18954921595377697, 0.00841214218805011, 6.609348901400682},
    {Baseline::kPizza, 1, 0.20224298189498383, 0.008084932740792522, 6.579275799540185},
    {Baseline::kPizza, 2, 0.20237238652375558, 0.009650811011024291, 6.527974293216743},
    {Baseline::kPizza, 5, 0.197800450478216, 0.010994221094487996, 6.377864042127233},
};

TEST(PublishedTest, DeterministicBaselinesReproduceThePublishedScores) {
  absl::StatusOr<SearchArea> a = DatasetOneMedium();
  ASSERT_TRUE(a.ok()) << a.status();
  for (const PublishedRow& row : kPublished) {
    SCOPED_TRACE(testing::Message() << BaselineName(row.baseline) << " n=" << row.n);
    absl::StatusOr<std::vector<Polyline>> paths = PlanBaseline(row.baseline, *a, row.n, 100000, 1);
    ASSERT_TRUE(paths.ok()) << paths.status();
    absl::StatusOr<PathMetrics> m = EvaluatePaths(*a, *paths, {});
    ASSERT_TRUE(m.ok()) << m.status();
    EXPECT_NEAR(m->likelihood, row.likelihood, 1e-5 * row.likelihood);
    EXPECT_NEAR(m->time_discounted, row.time_discounted, 1e-5 * row.time_discounted);
    EXPECT_NEAR(m->area_covered_km2, row.area_km2, 1e-5 * row.area_km2);
    EXPECT_NEAR(m->total_path_length_km, 100, 1e-9);
  }
}

TEST(BaselinesTest, SpiralPiecesFollowOneAnother) {
  absl::StatusOr<SearchArea> a = DatasetOneMedium();
  ASSERT_TRUE(a.ok()) << a.status();
  absl::StatusOr<std::vector<Polyline>> p = PlanBaseline(Baseline::kSpiral, *a, 2, 300000, 1);
  ASSERT_TRUE(p.ok()) << p.status();
  ASSERT_EQ(p->size(), 2u);
  // 300 km is more than the whole spiral: each drone flies half of it.
  EXPECT_NEAR((*p)[0].back().x_m, (*p)[1].front().x_m, 1e-6);
  EXPECT_NEAR((*p)[0].back().y_m, (*p)[1].front().y_m, 1e-6);
  EXPECT_NEAR((*p)[0].front().x_m, a->center_x_m, 1e-9);
}

TEST(BaselinesTest, PizzaDronesStartInTheCentreInSectorsOfTheirOwn) {
  absl::StatusOr<SearchArea> a = DatasetOneMedium();
  ASSERT_TRUE(a.ok()) << a.status();
  absl::StatusOr<std::vector<Polyline>> p = PlanBaseline(Baseline::kPizza, *a, 4, 100000, 1);
  ASSERT_TRUE(p.ok()) << p.status();
  ASSERT_EQ(p->size(), 4u);
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ((*p)[k].front().x_m, a->center_x_m);
    // The first arc of drone k lies in quadrant k (counter-clockwise from +x).
    const double angle = std::atan2((*p)[k][1].y_m - a->center_y_m, (*p)[k][1].x_m - a->center_x_m);
    const double from = k * std::numbers::pi / 2;
    EXPECT_GE(std::fmod(angle + 2 * std::numbers::pi, 2 * std::numbers::pi), from);
    EXPECT_LE(std::fmod(angle + 2 * std::numbers::pi, 2 * std::numbers::pi),
              from + std::numbers::pi / 2);
    EXPECT_NEAR(PolylineLength_m((*p)[k]), 25000, 1e-6);
  }
}

TEST(BaselinesTest, GreedyAndRandomWalkStepBetweenNeighbouringCellsWithinTheDisc) {
  absl::StatusOr<SearchArea> a = DatasetOneMedium();
  ASSERT_TRUE(a.ok()) << a.status();
  for (const Baseline b : {Baseline::kGreedy, Baseline::kRandomWalk}) {
    SCOPED_TRACE(BaselineName(b));
    absl::StatusOr<std::vector<Polyline>> p = PlanBaseline(b, *a, 2, 20000, 3);
    ASSERT_TRUE(p.ok()) << p.status();
    ASSERT_EQ(p->size(), 2u);
    for (const Polyline& path : *p) {
      EXPECT_NEAR(PolylineLength_m(path), 10000, 1e-6);
      for (size_t i = 1; i + 1 < path.size(); ++i) {  // the last step may be cut short
        const double step =
            std::hypot(path[i].x_m - path[i - 1].x_m, path[i].y_m - path[i - 1].y_m);
        EXPECT_TRUE(std::abs(step - 30) < 1e-6 || std::abs(step - 30 * std::numbers::sqrt2) < 1e-6)
            << step;
        EXPECT_LT(std::hypot(path[i].x_m - a->center_x_m, path[i].y_m - a->center_y_m), 1800);
      }
    }
    absl::StatusOr<std::vector<Polyline>> same = PlanBaseline(b, *a, 2, 20000, 3);
    EXPECT_EQ((*same)[1].back().x_m, (*p)[1].back().x_m);
  }
  absl::StatusOr<std::vector<Polyline>> w1 = PlanBaseline(Baseline::kRandomWalk, *a, 1, 20000, 1);
  absl::StatusOr<std::vector<Polyline>> w2 = PlanBaseline(Baseline::kRandomWalk, *a, 1, 20000, 2);
  EXPECT_FALSE((*w1)[0].back().x_m == (*w2)[0].back().x_m &&
               (*w1)[0].back().y_m == (*w2)[0].back().y_m);
}

TEST(BaselinesTest, NamesAndBadRequests) {
  EXPECT_EQ(*ParseBaseline("randomwalk"), Baseline::kRandomWalk);
  EXPECT_EQ(BaselineName(*ParseBaseline("PIZZA")), "Pizza");
  EXPECT_FALSE(ParseBaseline("zigzag").ok());
  EXPECT_FALSE(PlanBaseline(Baseline::kSpiral, NineCells(), 0, 1000, 1).ok());
  EXPECT_FALSE(PlanBaseline(Baseline::kSpiral, NineCells(), 1, -5, 1).ok());
}

}  // namespace
}  // namespace oaipp::sarenv
