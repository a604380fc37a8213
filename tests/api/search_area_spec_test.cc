// MissionSpec.search_areas through the spec conversion: the cells a spec's
// area marks (drawn here by hand), the area kept through GetMission's
// spec and back, and every refusal naming the spec's field.
#include <cstdint>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "api/spec.h"
#include "gtest/gtest.h"

namespace oaipp::api {
namespace {

void AddRing(std::initializer_list<double> xy, v1::Ring* ring) {
  for (const double v : xy) ring->add_xy_m(v);
}

// The field [0, 8] x [0, 6] at 1 m and the L with a square hole of the
// drawing (as tests/api/search_area_test.cc draws it):
//
//   6 +-------+
//   4 | +---+ |
//   3 | |   | +-------+
//   2 | +---+         |
//   0 +---------------+
//     0   2   4       8  x (m)
v1::MissionSpec LSpec() {
  v1::MissionSpec spec;
  v1::FieldSpec& f = *spec.mutable_field();
  f.set_x_min_m(0);
  f.set_y_min_m(0);
  f.set_x_max_m(8);
  f.set_y_max_m(6);
  f.set_resolution_m(1.0);
  spec.mutable_start()->mutable_position_m()->set_x(0.5);
  spec.mutable_start()->mutable_position_m()->set_y(0.5);
  spec.mutable_start()->mutable_position_m()->set_z(2.0);
  v1::AreaPolygon& l = *spec.add_search_areas();
  AddRing({0, 0, 8, 0, 8, 3, 4, 3, 4, 6, 0, 6}, l.mutable_outer());
  AddRing({1, 2, 1, 4, 3, 4, 3, 2}, l.add_holes());
  return spec;
}

TEST(SearchAreaSpecTest, TheSpecsAreaMarksTheCellsDrawnAndSurvivesTheRoundTrip) {
  const absl::StatusOr<MissionConfig> config = MissionSpecToConfig(LSpec());
  ASSERT_TRUE(config.ok()) << config.status();
  ASSERT_NE(config->search_area, nullptr);
  // Row by row from y = 0.5 up (the grid's order, row * nx + col).
  const std::vector<std::uint8_t> expected = {
      1, 1, 1, 1, 1, 1, 1, 1,  // y 0.5
      1, 1, 1, 1, 1, 1, 1, 1,  // y 1.5
      1, 0, 0, 1, 1, 1, 1, 1,  // y 2.5: the hole's lower half
      1, 0, 0, 1, 0, 0, 0, 0,  // y 3.5
      1, 1, 1, 1, 0, 0, 0, 0,  // y 4.5
      1, 1, 1, 1, 0, 0, 0, 0,  // y 5.5
  };
  EXPECT_EQ(config->search_area->mask, expected);
  ASSERT_EQ(config->search_area->polygons.size(), 1u);
  EXPECT_EQ(config->search_area->polygons[0].outer_m.size(), 6u);
  ASSERT_EQ(config->search_area->polygons[0].holes_m.size(), 1u);

  // GetMission's spec carries the area; read again, it is the same area.
  const v1::MissionSpec effective = ConfigToMissionSpec(*config);
  ASSERT_EQ(effective.search_areas_size(), 1);
  EXPECT_EQ(effective.search_areas(0).outer().xy_m_size(), 12);
  EXPECT_EQ(effective.search_areas(0).holes(0).xy_m_size(), 8);
  const absl::StatusOr<MissionConfig> again = MissionSpecToConfig(effective);
  ASSERT_TRUE(again.ok()) << again.status();
  ASSERT_NE(again->search_area, nullptr);
  EXPECT_EQ(again->search_area->polygons[0].outer_m, config->search_area->polygons[0].outer_m);
  EXPECT_EQ(again->search_area->polygons[0].holes_m, config->search_area->polygons[0].holes_m);
  EXPECT_EQ(again->search_area->mask, expected);

  // No area: no mask, the whole field.
  v1::MissionSpec whole = LSpec();
  whole.clear_search_areas();
  const absl::StatusOr<MissionConfig> plain = MissionSpecToConfig(whole);
  ASSERT_TRUE(plain.ok()) << plain.status();
  EXPECT_EQ(plain->search_area, nullptr);
  EXPECT_EQ(ConfigToMissionSpec(*plain).search_areas_size(), 0);
}

TEST(SearchAreaSpecTest, EveryBadAreaIsRefusedNamingTheSpecsField) {
  struct Case {
    std::string name;
    void (*edit)(v1::MissionSpec&);
    std::string prefix;
  };
  const std::vector<Case> cases = {
      {"odd count",
       [](v1::MissionSpec& s) { s.mutable_search_areas(0)->mutable_outer()->add_xy_m(1); },
       "spec.search_areas[0].outer.xy_m: 13 values"},
      {"bow-tie hole",
       [](v1::MissionSpec& s) {
         v1::Ring* h = s.mutable_search_areas(0)->mutable_holes(0);
         h->clear_xy_m();
         AddRing({1, 2, 3, 4, 3, 2, 1, 4}, h);
       },
       "spec.search_areas[0].holes[0]: "},
      {"open outer (two vertices)",
       [](v1::MissionSpec& s) {
         v1::AreaPolygon& a = *s.add_search_areas();
         AddRing({0, 0, 1, 1}, a.mutable_outer());
       },
       "spec.search_areas[1].outer: "},
      {"hole outside its area",
       [](v1::MissionSpec& s) {
         v1::Ring* h = s.mutable_search_areas(0)->mutable_holes(0);
         h->clear_xy_m();
         AddRing({5, 4, 7, 4, 7, 5, 5, 5}, h);
       },
       "spec.search_areas[0].holes[0]: "},
      {"off the field",
       [](v1::MissionSpec& s) {
         s.clear_search_areas();
         AddRing({20, 20, 30, 20, 30, 30}, s.add_search_areas()->mutable_outer());
       },
       "spec.search_areas: holds the centre of no cell"},
      {"too many vertices",
       [](v1::MissionSpec& s) {
         v1::Ring* r = s.mutable_search_areas(0)->mutable_outer();
         for (int i = 0; i < 20'000; ++i) r->add_xy_m(0.5);
       },
       "spec.search_areas: 10010 vertices in all, more than 10000"},
  };
  for (const Case& c : cases) {
    v1::MissionSpec spec = LSpec();
    c.edit(spec);
    const absl::StatusOr<MissionConfig> config = MissionSpecToConfig(spec);
    ASSERT_FALSE(config.ok()) << c.name;
    EXPECT_EQ(config.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_TRUE(absl::StartsWith(config.status().message(), c.prefix))
        << c.name << ": " << config.status().message();
    EXPECT_LE(config.status().message().size(), 300u) << c.name;
  }
}

}  // namespace
}  // namespace oaipp::api
