// Seeded random worlds for environment tests.
#pragma once

#include <random>
#include <string>
#include <vector>

#include "core/environment/obstacle.h"

namespace oaipp::testing {

// The E1 flight volume: 30 x 30 m field, 26 m ceiling.
inline Aabb E1Volume() { return {{-15, -15, 0}, {15, 15, 26}}; }

// `count` boxes and vertical cylinders standing on the ground at random
// places, sizes and yaws (some poking out of the volume), from `seed`.
inline std::vector<Obstacle> RandomObstacles(unsigned seed, int count) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(-17.0, 17.0), size(0.3, 8.0), height(1.0, 30.0),
      yaw(-3.2, 3.2), coin(0.0, 1.0);
  std::vector<Obstacle> out;
  for (int i = 0; i < count; ++i) {
    const double h = height(rng);
    const Vec3 base(pos(rng), pos(rng), 0.0);
    if (coin(rng) < 0.6) {
      out.push_back({"box" + std::to_string(i),
                     Box{base + Vec3(0, 0, h / 2), Vec3(size(rng), size(rng), h), yaw(rng)}});
    } else {
      out.push_back(
          {"cyl" + std::to_string(i), Cylinder{base + Vec3(0, 0, h / 2), size(rng) / 2, h}});
    }
  }
  return out;
}

}  // namespace oaipp::testing
