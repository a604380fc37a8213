// HashRing against the routing of a real HAProxy 2.6.12 (Debian 12's),
// configured as deploy/cluster/haproxy.cfg.in (`balance
// hdr(x-oaipp-mission)`, `hash-type consistent`, `server replica-N ... id
// N`): for each set of live servers, the server it sent a request with
// `x-oaipp-mission: m-0` ... `m-23` to. Recorded by hand with curl against
// plain HTTP servers that answered their own name.
#include "server/hash_ring.h"

#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"

namespace oaipp::server {
namespace {

struct Recorded {
  std::vector<int> live;
  std::vector<int> routed;  // for m-0 ... m-23
};

TEST(HashRingTest, PicksTheServerHaproxyPicks) {
  const std::vector<Recorded> recorded = {
      {{1, 2, 3}, {3, 2, 3, 1, 1, 1, 2, 2, 2, 3, 1, 1, 1, 2, 3, 2, 2, 3, 1, 3, 2, 3, 1, 2}},
      {{1, 3}, {3, 3, 3, 1, 1, 1, 3, 3, 1, 3, 1, 1, 1, 3, 3, 3, 3, 3, 1, 3, 1, 3, 1, 3}},
      {{2, 3}, {3, 2, 3, 3, 3, 3, 2, 2, 2, 3, 2, 2, 3, 2, 3, 2, 2, 3, 3, 3, 2, 3, 3, 2}},
      {{1, 2}, {1, 2, 1, 1, 1, 1, 2, 2, 2, 2, 1, 1, 1, 2, 2, 2, 2, 2, 1, 2, 2, 2, 1, 2}},
      {{1, 2, 3, 4}, {3, 4, 3, 1, 1, 1, 2, 4, 2, 3, 1, 1, 4, 2, 4, 4, 4, 4, 1, 4, 2, 3, 1, 2}},
      {{1, 2, 4}, {1, 4, 1, 1, 1, 1, 2, 4, 2, 2, 1, 1, 4, 2, 4, 4, 4, 4, 1, 4, 2, 2, 1, 2}},
  };
  for (const Recorded& r : recorded) {
    const HashRing ring(r.live);
    for (int m = 0; m < static_cast<int>(r.routed.size()); ++m) {
      EXPECT_EQ(ring.Pick(HashRing::RouteHash(absl::StrCat("m-", m))), r.routed[m])
          << "m-" << m << " with " << r.live.size() << " servers, the first " << r.live[0];
    }
  }
}

TEST(HashRingTest, AnEmptyRingPicksNobodyAndBadIdsAreLeftOut) {
  EXPECT_EQ(HashRing({}).Pick(12345), 0);
  EXPECT_EQ(HashRing({0, -3}).Pick(12345), 0);
  const HashRing one({0, 7});
  for (std::uint32_t h : {0U, 1U, 0x80000000U, 0xffffffffU}) EXPECT_EQ(one.Pick(h), 7);
}

}  // namespace
}  // namespace oaipp::server
