#include "sim/random_world.h"

#include <cmath>

#include "gtest/gtest.h"
#include "sim/scenario.h"
#include "sim/simulation.h"

namespace oaipp::sim {
namespace {

v1::Scenario E1Scenario() {
  absl::StatusOr<v1::Scenario> s = LoadScenarioFile(OAIPP_SCENARIO_DIR "/e1.json");
  EXPECT_TRUE(s.ok()) << s.status();
  return *s;
}

struct Footprint {
  double x0, y0, x1, y1;
};

Footprint Of(const v1::Obstacle& o) {
  const auto& c = o.box().centre_m();
  const auto& s = o.box().size_m();
  return {c.x() - s.x() / 2, c.y() - s.y() / 2, c.x() + s.x() / 2, c.y() + s.y() / 2};
}

bool Overlap(const Footprint& a, const Footprint& b, double gap) {
  return a.x0 < b.x1 + gap && b.x0 < a.x1 + gap && a.y0 < b.y1 + gap && b.y0 < a.y1 + gap;
}

class RandomWorldTest : public ::testing::TestWithParam<BuildingKind> {};

// Checked against the scenario itself (field, targets, start), not against
// the generator's own bookkeeping.
TEST_P(RandomWorldTest, PlacesBuildingsClearOfTargetsStartAndEachOther) {
  const v1::Scenario base = E1Scenario();
  const double height = GetParam() == BuildingKind::kLowRise ? 13.0 : 26.0;
  for (int count : {5, 10, 15}) {
    for (std::uint64_t seed = 1; seed <= 10; ++seed) {
      const RandomWorldOptions options{.kind = GetParam(), .count = count, .seed = seed};
      absl::StatusOr<v1::Scenario> world = RandomWorld(base, options);
      ASSERT_TRUE(world.ok()) << world.status();
      ASSERT_EQ(world->mission().obstacles_size(), count);
      EXPECT_EQ(world->targets_size(), base.targets_size());
      for (int i = 0; i < count; ++i) {
        const v1::Obstacle& o = world->mission().obstacles(i);
        EXPECT_DOUBLE_EQ(o.box().size_m().x(), 4.0);
        EXPECT_DOUBLE_EQ(o.box().size_m().y(), 4.0);
        EXPECT_DOUBLE_EQ(o.box().size_m().z(), height);
        EXPECT_DOUBLE_EQ(o.box().centre_m().z(), height / 2);
        const Footprint f = Of(o);
        EXPECT_GE(f.x0, -15.0);
        EXPECT_LE(f.x1, 15.0);
        EXPECT_GE(f.y0, -15.0);
        EXPECT_LE(f.y1, 15.0);
        // The E1 start (10, 0): at least 4 m away horizontally.
        const double dx = std::max({f.x0 - 10.0, 0.0, 10.0 - f.x1});
        const double dy = std::max({f.y0 - 0.0, 0.0, 0.0 - f.y1});
        EXPECT_GE(std::hypot(dx, dy), 4.0 - 1e-9);
        for (const v1::Target& t : base.targets()) {
          EXPECT_FALSE(Overlap(f, {t.x_min_m(), t.y_min_m(), t.x_max_m(), t.y_max_m()}, 1.0))
              << o.id() << " over " << t.id();
        }
        for (int j = 0; j < i; ++j) {
          EXPECT_FALSE(Overlap(f, Of(world->mission().obstacles(j)), 1.0 - 1e-9))
              << o.id() << " and " << world->mission().obstacles(j).id();
        }
      }
      // A valid mission for the client's simulation (and so the server).
      EXPECT_TRUE(Simulation::Create(*world).ok());
    }
  }
}

INSTANTIATE_TEST_SUITE_P(BothKinds, RandomWorldTest,
                         ::testing::Values(BuildingKind::kLowRise, BuildingKind::kHighRise));

TEST(RandomWorldTest, SameSeedSameWorld) {
  const v1::Scenario base = E1Scenario();
  auto a = RandomWorld(base, {.count = 10, .seed = 3});
  auto b = RandomWorld(base, {.count = 10, .seed = 3});
  auto c = RandomWorld(base, {.count = 10, .seed = 4});
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  EXPECT_EQ(a->SerializeAsString(), b->SerializeAsString());
  EXPECT_NE(a->SerializeAsString(), c->SerializeAsString());
}

TEST(RandomWorldTest, BadOptionsAndFullFields) {
  const v1::Scenario base = E1Scenario();
  absl::Status s = RandomWorld(base, {.count = 41}).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("count"), std::string::npos) << s;
  s = RandomWorld(base, {.gap_m = -1}).status();
  EXPECT_NE(s.message().find("gap_m"), std::string::npos) << s;
  // 40 buildings 10 m apart cannot fit in 30 x 30 m.
  s = RandomWorld(base, {.count = 40, .gap_m = 10}).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(s.message().find("no free place for 40 buildings"), std::string::npos) << s;
}

}  // namespace
}  // namespace oaipp::sim
