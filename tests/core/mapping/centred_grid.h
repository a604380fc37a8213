// A field grid centred on the origin, for the mapping tests.
#pragma once

#include "core/mapping/field_grid.h"
#include "gtest/gtest.h"

namespace oaipp::testing {

// nx x ny cells of edge res metres, centred on (0, 0).
inline FieldGrid CentredGrid(int nx, int ny, double res) {
  auto grid = FieldGrid::Create(Vec2(-0.5 * nx * res, -0.5 * ny * res), nx, ny, res);
  EXPECT_TRUE(grid.ok()) << grid.status();
  return *grid;
}

}  // namespace oaipp::testing
