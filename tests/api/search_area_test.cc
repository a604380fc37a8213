// api/search_area.h against numbers from outside it: masks drawn and
// counted by hand, areas from their closed forms, and an even-odd
// ray-casting point-in-polygon written here, with no GEOS, as the twin of
// the mask on seeded random polygons.
#include "api/search_area.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "core/common/field_error.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace oaipp::api {
namespace {

using ::testing::HasSubstr;

// A mask drawn as a map is, north up: the first line is the grid's last
// row (largest y), '#' is 1 and '.' is 0.
std::vector<std::uint8_t> Drawn(const std::vector<std::string>& lines) {
  std::vector<std::uint8_t> mask;
  for (auto line = lines.rbegin(); line != lines.rend(); ++line) {
    for (const char c : *line) mask.push_back(c == '#' ? 1 : 0);
  }
  return mask;
}

// The square [x0, x1] x [y0, y1], counter-clockwise.
std::vector<Vec2> Square(double x0, double y0, double x1, double y1) {
  return {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
}

std::vector<Vec2> Reversed(std::vector<Vec2> ring) {
  std::reverse(ring.begin(), ring.end());
  return ring;
}

// The L of the drawing below, with a square hole across its inner corner's
// row. 1 m cells over [0, 8] x [0, 6]: no centre lies on a ring.
//
//   y
//   6 +-------+
//   5 |       |
//   4 | +---+ |
//   3 | |   | +-------+
//   2 | +---+         |
//   1 |               |
//   0 +---------------+
//     0 1 2 3 4 5 6 7 8  x (m)
AreaPolygon LWithHole() {
  return {.outer_m = {{0, 0}, {8, 0}, {8, 3}, {4, 3}, {4, 6}, {0, 6}},
          .holes_m = {Reversed(Square(1, 2, 3, 4))}};
}

TEST(SearchAreaMaskTest, AConcaveAreaWithAHoleMarksTheCellsDrawn) {
  const FieldGrid grid = *FieldGrid::FromBounds({0, 0}, {8, 6}, 1.0);
  const std::vector<std::uint8_t> expected = Drawn({
      "####....",  // y 5.5
      "####....",  // y 4.5
      "#..#....",  // y 3.5: the hole's upper half
      "#..#####",  // y 2.5: its lower half
      "########",  // y 1.5
      "########",  // y 0.5
  });
  const std::vector<AreaPolygon> areas = {LWithHole()};
  ASSERT_TRUE(ValidateSearchArea(areas, "search_areas").ok());
  const absl::StatusOr<std::vector<std::uint8_t>> mask = SearchAreaMask(areas, grid);
  ASSERT_TRUE(mask.ok()) << mask.status();
  EXPECT_EQ(*mask, expected);

  // Either orientation of either ring: the same ground.
  const std::vector<AreaPolygon> flipped = {
      {.outer_m = Reversed(areas[0].outer_m), .holes_m = {Square(1, 2, 3, 4)}}};
  EXPECT_EQ(*SearchAreaMask(flipped, grid), expected);
}

TEST(SearchAreaSizeTest, TheLWithAHoleHasItsClosedFormArea) {
  // 8 x 3 + 4 x 3 - 2 x 2 = 32 m^2, as many as the drawn mask's 1 m cells.
  const std::vector<AreaPolygon> areas = {LWithHole()};
  const absl::StatusOr<double> area_m2 = SearchAreaSize_m2(areas);
  ASSERT_TRUE(area_m2.ok()) << area_m2.status();
  EXPECT_DOUBLE_EQ(*area_m2, 32.0);
}

TEST(SearchAreaMaskTest, ACentreOnARingCountsAsInside) {
  // Outer [0, 4]^2, hole [1, 3]^2; 1 m cells with centres on whole metres,
  // so rows and columns 0 and 4 lie on the outer ring and 1 and 3 on the
  // hole's: all inside. Only (2, 2), inside the hole, and x or y = 5 are out.
  const FieldGrid grid = *FieldGrid::Create({-0.5, -0.5}, 6, 6, 1.0);
  const std::vector<AreaPolygon> areas = {
      {.outer_m = Square(0, 0, 4, 4), .holes_m = {Square(1, 1, 3, 3)}}};
  EXPECT_EQ(*SearchAreaMask(areas, grid), Drawn({
                                              "......",  // y 5
                                              "#####.",  // y 4
                                              "#####.",  // y 3
                                              "##.##.",  // y 2
                                              "#####.",  // y 1
                                              "#####.",  // y 0
                                          }));
}

TEST(SearchAreaMaskTest, OverlappingAreasAreUnitedAndFillEachOthersHoles) {
  // A: [0, 4]^2 less the hole [1, 3]^2; B: [2, 6] x [1.2, 2.8], across A's
  // hole and out past A. C touches A along x = 0 (from the left, off the
  // grid): touching and overlapping are both accepted.
  const std::vector<AreaPolygon> areas = {
      {.outer_m = Square(0, 0, 4, 4), .holes_m = {Square(1, 1, 3, 3)}},
      {.outer_m = Square(2, 1.2, 6, 2.8)},
      {.outer_m = Square(-3, 0, 0, 4)}};
  ASSERT_TRUE(ValidateSearchArea(areas, "search_areas").ok());
  const FieldGrid grid = *FieldGrid::FromBounds({0, 0}, {6, 4}, 1.0);
  EXPECT_EQ(*SearchAreaMask(areas, grid), Drawn({
                                              "####..",  // y 3.5
                                              "#.####",  // y 2.5
                                              "#.####",  // y 1.5
                                              "####..",  // y 0.5
                                          }));
  // A 16 - 4 = 12, B 4 x 1.6 = 6.4, A and B share [2, 4] x [1.2, 2.8] less
  // the hole's [2, 3] x [1.2, 2.8]: 3.2 - 1.6 = 1.6; C 3 x 4 = 12.
  EXPECT_NEAR(*SearchAreaSize_m2(areas), 12.0 + 6.4 - 1.6 + 12.0, 1e-12);
}

TEST(SearchAreaTest, NoAreaSearchesNothing) {
  const std::vector<AreaPolygon> none;
  EXPECT_TRUE(ValidateSearchArea(none, "search_areas").ok());
  const FieldGrid grid = *FieldGrid::FromBounds({0, 0}, {3, 2}, 1.0);
  EXPECT_EQ(*SearchAreaMask(none, grid), std::vector<std::uint8_t>(6, 0));
  EXPECT_EQ(*SearchAreaSize_m2(none), 0.0);
}

// ---------------------------------------------------------------- the twin

// Even-odd rule: a ray from p towards +x crosses the rings of a polygon
// with holes an odd number of times exactly when p is inside it (Shimrat,
// "Algorithm 112: Position of point relative to polygon", CACM 1962).
bool InsideEvenOdd(const AreaPolygon& area, const Vec2& p) {
  bool inside = false;
  const auto cross = [&](const std::vector<Vec2>& ring) {
    for (std::size_t k = 0, prev = ring.size() - 1; k < ring.size(); prev = k++) {
      const Vec2& a = ring[prev];
      const Vec2& b = ring[k];
      if ((a.y() > p.y()) != (b.y() > p.y()) &&
          p.x() < a.x() + (p.y() - a.y()) * (b.x() - a.x()) / (b.y() - a.y())) {
        inside = !inside;
      }
    }
  };
  cross(area.outer_m);
  for (const std::vector<Vec2>& hole : area.holes_m) cross(hole);
  return inside;
}

double DistanceToSegment(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (a + t * ab - p).norm();
}

double DistanceToRings(const AreaPolygon& area, const Vec2& p) {
  double d = std::numeric_limits<double>::infinity();
  const auto ring_distance = [&](const std::vector<Vec2>& ring) {
    for (std::size_t k = 0, prev = ring.size() - 1; k < ring.size(); prev = k++) {
      d = std::min(d, DistanceToSegment(p, ring[prev], ring[k]));
    }
  };
  ring_distance(area.outer_m);
  for (const std::vector<Vec2>& hole : area.holes_m) ring_distance(hole);
  return d;
}

// Twice the signed area (shoelace formula).
double TwiceSignedArea(const std::vector<Vec2>& ring) {
  double sum = 0.0;
  for (std::size_t k = 0, prev = ring.size() - 1; k < ring.size(); prev = k++) {
    sum += ring[prev].x() * ring[k].y() - ring[k].x() * ring[prev].y();
  }
  return sum;
}

// A polygon star-shaped about `centre`: n vertices at increasing angles
// (each jittered within a third of the step, so that gaps stay below pi),
// radii in [r_min, r_max]. Star-shaped with sorted angles means simple.
std::vector<Vec2> Star(std::mt19937& rng, const Vec2& centre, int n, double r_min, double r_max) {
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);
  std::uniform_real_distribution<double> radius(r_min, r_max);
  const double phase = std::uniform_real_distribution<double>(0.0, 2.0 * kPi)(rng);
  std::vector<Vec2> ring;
  for (int k = 0; k < n; ++k) {
    const double angle = phase + (k + jitter(rng)) * 2.0 * kPi / n;
    const double r = radius(rng);
    ring.emplace_back(centre.x() + r * std::cos(angle), centre.y() + r * std::sin(angle));
  }
  if (std::bernoulli_distribution(0.5)(rng)) std::reverse(ring.begin(), ring.end());
  return ring;
}

// A random star with a random star hole inside the disc about its centre
// that none of its edges reaches (the star, being star-shaped about that
// centre, holds the whole disc): simple rings, the hole strictly inside.
AreaPolygon RandomAreaWithHole(std::mt19937& rng) {
  std::uniform_real_distribution<double> coord(-8.0, 8.0);
  const Vec2 centre(coord(rng), coord(rng));
  const int n = std::uniform_int_distribution<int>(5, 40)(rng);
  const double r_min = std::uniform_real_distribution<double>(3.0, 6.0)(rng);
  const double r_max = r_min * std::uniform_real_distribution<double>(1.2, 2.5)(rng);
  AreaPolygon area{.outer_m = Star(rng, centre, n, r_min, r_max)};
  double clear_m = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0, prev = area.outer_m.size() - 1; k < area.outer_m.size(); prev = k++) {
    clear_m = std::min(clear_m, DistanceToSegment(centre, area.outer_m[prev], area.outer_m[k]));
  }
  std::uniform_real_distribution<double> offset(-0.25 * clear_m, 0.25 * clear_m);
  const Vec2 hole_centre = centre + Vec2(offset(rng), offset(rng));
  const int m = std::uniform_int_distribution<int>(3, 12)(rng);
  // Within 0.25 sqrt(2) + 0.6 < 0.96 of clear_m from the centre.
  area.holes_m.push_back(Star(rng, hole_centre, m, 0.1 * clear_m, 0.6 * clear_m));
  return area;
}

TEST(SearchAreaMaskTest, MatchesEvenOddRayCastingOnRandomStarsWithHoles) {
  std::mt19937 rng(20261207);
  const std::vector<FieldGrid> grids = {*FieldGrid::Create({-20, -20}, 80, 80, 0.5),
                                        *FieldGrid::Create({-17.3, -19.1}, 37, 53, 0.9),
                                        *FieldGrid::Create({-21.05, -16.6}, 150, 110, 0.31)};
  int trials = 0;
  int redrawn = 0;
  int inside_cells = 0;
  while (trials < 24) {
    // One or two areas; two may overlap, and the searched ground is their
    // union: inside either by the even-odd rule.
    std::vector<AreaPolygon> areas = {RandomAreaWithHole(rng)};
    if (trials % 3 == 2) areas.push_back(RandomAreaWithHole(rng));
    const FieldGrid& grid = grids[static_cast<std::size_t>(trials) % grids.size()];
    std::vector<std::uint8_t> expected(static_cast<std::size_t>(grid.num_cells()));
    bool near_a_ring = false;
    for (int index = 0; index < grid.num_cells() && !near_a_ring; ++index) {
      const Vec2 c = grid.CellCentreXY(index);
      for (const AreaPolygon& area : areas) {
        // Keep every centre 1e-6 m off every ring: there the two rules
        // may differ by round-off, and a boundary centre has its own test.
        near_a_ring = near_a_ring || DistanceToRings(area, c) < 1e-6;
        expected[static_cast<std::size_t>(index)] |= InsideEvenOdd(area, c) ? 1 : 0;
      }
    }
    if (near_a_ring) {
      ++redrawn;
      continue;
    }
    ASSERT_TRUE(ValidateSearchArea(areas, "search_areas").ok()) << "trial " << trials;
    const absl::StatusOr<std::vector<std::uint8_t>> mask = SearchAreaMask(areas, grid);
    ASSERT_TRUE(mask.ok()) << mask.status();
    EXPECT_EQ(*mask, expected) << "trial " << trials;
    for (const std::uint8_t v : expected) inside_cells += v;
    if (areas.size() == 1) {
      // One area: its outer ring's area less its hole's (shoelace).
      const double expected_m2 = 0.5 * (std::abs(TwiceSignedArea(areas[0].outer_m)) -
                                        std::abs(TwiceSignedArea(areas[0].holes_m[0])));
      EXPECT_NEAR(*SearchAreaSize_m2(areas), expected_m2, 1e-9 * expected_m2) << "trial " << trials;
    }
    ++trials;
  }
  // The drawing exercised both answers, and random coordinates almost never
  // put a centre within a micrometre of a ring.
  EXPECT_GT(inside_cells, 10'000);
  EXPECT_LE(redrawn, 2);
}

// ---------------------------------------------------------------- refusals

struct Refusal {
  const char* what;
  std::vector<AreaPolygon> areas;
  std::string message;  // a part of the expected message
};

std::vector<Vec2> Circle(int n, double radius_m) {
  std::vector<Vec2> ring;
  for (int k = 0; k < n; ++k) {
    const double angle = 2.0 * kPi * k / n;
    ring.emplace_back(radius_m * std::cos(angle), radius_m * std::sin(angle));
  }
  return ring;
}

TEST(ValidateSearchAreaTest, EveryBadAreaIsRefusedNamingItsField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const AreaPolygon good{.outer_m = Square(0, 0, 1, 1)};
  const std::vector<Refusal> refusals = {
      {"a bow-tie",
       {{.outer_m = {{0, 0}, {2, 2}, {2, 0}, {0, 2}}}},
       "search_areas[0].outer: self-intersecting near (1.00, 1.00) m"},
      {"a bow-tie hole in the second area",
       {good, {.outer_m = Square(0, 0, 10, 10), .holes_m = {{{2, 2}, {4, 4}, {4, 2}, {2, 4}}}}},
       "search_areas[1].holes[0]: self-intersecting near (3.00, 3.00) m"},
      {"a ring that touches itself at a vertex: two triangles tip to tip",
       {{.outer_m = {{0, 0}, {2, 0}, {4, 0}, {4, 4}, {2, 0}, {0, 4}}}},
       "search_areas[0].outer: self-intersecting near (2.00, 0.00) m"},
      {"a ring with 2 vertices",
       {{.outer_m = {{0, 0}, {1, 0}}}},
       "search_areas[0].outer: needs at least 3 distinct vertices, got 2"},
      {"3 vertices, 2 of them the same",
       {good, {.outer_m = Square(0, 0, 5, 5), .holes_m = {{{1, 1}, {2, 1}, {1, 1}}}}},
       "search_areas[1].holes[0]: needs at least 3 distinct vertices, got 2"},
      {"an empty ring", {{.outer_m = {}}}, "search_areas[0].outer: needs at least 3"},
      {"3 distinct vertices on a line",
       {{.outer_m = {{0, 0}, {1, 0}, {2, 0}}}},
       "search_areas[0].outer: self-intersecting"},
      {"a NaN",
       {{.outer_m = {{0, 0}, {1, 0}, {1, nan}, {0, 1}}}},
       "search_areas[0].outer: vertex 2 is not finite"},
      {"an infinity in a hole",
       {{.outer_m = Square(0, 0, 5, 5), .holes_m = {{{1, 1}, {inf, 1}, {1, 2}}}}},
       "search_areas[0].holes[0]: vertex 1 is not finite"},
      {"a vertex 2000 km away",
       {{.outer_m = {{0, 0}, {2e6, 0}, {0, 1}}}},
       "search_areas[0].outer: vertex 1 is more than 1000 km from the origin"},
      {"a hole outside its outer ring",
       {{.outer_m = Square(0, 0, 4, 4), .holes_m = {Square(5, 5, 6, 6)}}},
       "search_areas[0].holes[0]: lies outside the outer ring near"},
      {"a hole across its outer ring",
       {{.outer_m = Square(0, 0, 4, 4), .holes_m = {Square(3, 1, 5, 2)}}},
       "search_areas[0].holes[0]: crosses or runs along the outer ring near (4.00, 1.00) m"},
      {"a hole along its outer ring",
       {{.outer_m = Square(0, 0, 4, 4), .holes_m = {Square(0, 1, 2, 2)}}},
       "search_areas[0].holes[0]: crosses or runs along the outer ring near"},
      {"a hole that covers its outer ring",
       {{.outer_m = Square(1, 1, 2, 2), .holes_m = {Square(0, 0, 4, 4)}}},
       "search_areas[0].holes[0]: lies outside the outer ring"},
      {"two overlapping holes",
       {{.outer_m = Square(0, 0, 10, 10), .holes_m = {Square(1, 1, 4, 4), Square(3, 3, 6, 6)}}},
       "search_areas[0].holes[1]: overlaps search_areas[0].holes[0] near"},
      {"two holes sharing an edge",
       {{.outer_m = Square(0, 0, 10, 10), .holes_m = {Square(1, 1, 4, 4), Square(4, 1, 6, 4)}}},
       "search_areas[0].holes[1]: overlaps search_areas[0].holes[0] near"},
      {"a hole inside another",
       {{.outer_m = Square(0, 0, 10, 10),
         .holes_m = {Square(8.5, 8.5, 9.5, 9.5), Square(1, 1, 8, 8), Square(2, 2, 3, 3)}}},
       "search_areas[0].holes[2]: overlaps search_areas[0].holes[1] near"},
      {"a hole that cuts its area in four",
       {{.outer_m = Square(0, 0, 4, 4), .holes_m = {{{2, 0}, {4, 2}, {2, 4}, {0, 2}}}}},
       "search_areas[0]: its holes cut it into pieces near"},
      {"too many vertices",
       {{.outer_m = Circle(kMaxAreaVertices - 2, 100.0), .holes_m = {Square(0, 0, 1, 1)}}},
       "search_areas: 10002 vertices in all, more than 10000"},
  };
  for (const Refusal& r : refusals) {
    const absl::Status status = ValidateSearchArea(r.areas, "search_areas");
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << r.what << ": " << status;
    EXPECT_THAT(status.message(), HasSubstr(r.message)) << r.what;
    // The mask and the size refuse it too, naming the same field.
    EXPECT_THAT(SearchAreaSize_m2(r.areas).status().message(), HasSubstr(r.message)) << r.what;
  }
}

TEST(ValidateSearchAreaTest, TheFieldIsDataACallerCanRename) {
  const std::vector<AreaPolygon> areas = {
      {.outer_m = Square(0, 0, 10, 10), .holes_m = {Square(1, 1, 4, 4), Square(3, 3, 6, 6)}}};
  const absl::Status status = ValidateSearchArea(areas, "spec.search_areas");
  EXPECT_THAT(status.message(),
              HasSubstr("spec.search_areas[0].holes[1]: overlaps spec.search_areas[0].holes[0]"));
  const std::optional<FieldErrorData> data = FieldErrorOf(status);
  ASSERT_TRUE(data.has_value());
  EXPECT_THAT(data->fields, ::testing::ElementsAre("spec.search_areas[0].holes[1]",
                                                   "spec.search_areas[0].holes[0]"));
  // The mask, which knows no field, names the list "search_areas"; its
  // caller puts the list where its request has it.
  const FieldGrid grid = *FieldGrid::FromBounds({0, 0}, {10, 10}, 1.0);
  const absl::Status renamed =
      RenameErrorFields(SearchAreaMask(areas, grid).status(),
                        [](absl::string_view f) { return absl::StrCat("spec.", f); });
  EXPECT_EQ(renamed.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(renamed.message(),
              HasSubstr("spec.search_areas[0].holes[1]: overlaps spec.search_areas[0].holes[0]"));
}

TEST(ValidateSearchAreaTest, WhatOgcAllowsIsAccepted) {
  const std::vector<std::vector<AreaPolygon>> accepted = {
      // A hole touching its outer ring at one point, and another hole at one.
      {{.outer_m = Square(0, 0, 4, 4),
        .holes_m = {{{0, 2}, {1, 1}, {1, 3}}, {{1, 3}, {2, 3}, {2, 3.5}}}}},
      // The first vertex repeated at the end, and a vertex given twice in a row.
      {{.outer_m = {{0, 0}, {3, 0}, {3, 0}, {3, 3}, {0, 3}, {0, 0}}}},
      // Exactly the vertex bound.
      {{.outer_m = Circle(kMaxAreaVertices - 4, 100.0), .holes_m = {Square(0, 0, 1, 1)}}},
  };
  for (const std::vector<AreaPolygon>& areas : accepted) {
    EXPECT_TRUE(ValidateSearchArea(areas, "search_areas").ok())
        << ValidateSearchArea(areas, "search_areas");
  }
  // The repeated vertices change nothing: 3 x 3.
  EXPECT_DOUBLE_EQ(*SearchAreaSize_m2(accepted[1]), 9.0);
}

}  // namespace
}  // namespace oaipp::api
