#include "server/hash_ring.h"

#include <algorithm>

namespace oaipp::server {
namespace {

// Bob Jenkins' 32-bit integer mix followed by a multiplication that spreads
// the result over the ring: the "avalanche" both the points and the header
// hash go through.
std::uint32_t Avalanche(std::uint32_t a) {
  a = (a + 0x7ed55d16U) + (a << 12);
  a = (a ^ 0xc761c23cU) ^ (a >> 19);
  a = (a + 0x165667b1U) + (a << 5);
  a = (a + 0xd3a2646cU) ^ (a << 9);
  a = (a + 0xfd7046c5U) + (a << 3);
  a = (a ^ 0xb55a4f09U) ^ (a >> 16);
  return a * 3221225473U;
}

// A server of weight 1 has 16 points, numbered from id x 4096 (the range
// one server's points may take at the largest weight).
constexpr int kPointsPerServer = 16;
constexpr std::uint32_t kPointRange = 4096;

}  // namespace

HashRing::HashRing(const std::vector<int>& ids) {
  for (const int id : ids) {
    if (id <= 0) continue;
    for (int k = 0; k < kPointsPerServer; ++k) {
      points_.emplace_back(Avalanche(static_cast<std::uint32_t>(id) * kPointRange + k), id);
    }
  }
  std::sort(points_.begin(), points_.end());
}

std::uint32_t HashRing::RouteHash(absl::string_view route) {
  // sdbm over the header's bytes, read as signed chars as the proxy does.
  std::uint32_t hash = 0;
  for (const char c : route) {
    hash =
        static_cast<std::uint32_t>(static_cast<signed char>(c)) + (hash << 6) + (hash << 16) - hash;
  }
  return Avalanche(hash);
}

int HashRing::Pick(std::uint32_t hash) const {
  if (points_.empty()) return 0;
  auto next = std::lower_bound(points_.begin(), points_.end(), std::make_pair(hash, 0));
  if (next == points_.end()) next = points_.begin();
  const auto prev = next == points_.begin() ? points_.end() - 1 : next - 1;
  // Distances along the ring, modulo 2^32.
  const std::uint32_t before = hash - prev->first;
  const std::uint32_t after = next->first - hash;
  return before <= after ? prev->second : next->second;
}

}  // namespace oaipp::server
