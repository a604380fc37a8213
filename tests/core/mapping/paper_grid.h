// The paper's 40 x 40 grid of 0.75 m cells over [-15, 15]^2, for tests.
#pragma once

#include "core/mapping/field_grid.h"
#include "gtest/gtest.h"

namespace oaipp::testing {

inline FieldGrid PaperGrid() {
  auto grid = FieldGrid::FromBounds(Vec2(-15, -15), Vec2(15, 15), 0.75);
  EXPECT_TRUE(grid.ok()) << grid.status();
  return *grid;
}

}  // namespace oaipp::testing
