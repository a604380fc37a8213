// The request_id memo behind every idempotent mutation: first result kept,
// empty ids never remembered, oldest forgotten past the capacity; and the
// bytes a mission's remembered answers count against its memory.
#include "server/request_memo.h"

#include <cstdint>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "gtest/gtest.h"
#include "server/idempotency_memo.h"

namespace oaipp::server {
namespace {

TEST(RequestMemoTest, KeepsTheFirstResultOfAnId) {
  RequestMemo<int> memo;
  EXPECT_EQ(memo.Find("a"), nullptr);
  memo.Remember("a", 1);
  memo.Remember("a", 2);  // a retry does not overwrite the first answer
  ASSERT_NE(memo.Find("a"), nullptr);
  EXPECT_EQ(*memo.Find("a"), 1);
}

TEST(RequestMemoTest, EmptyIdsAreNeverRemembered) {
  RequestMemo<int> memo;
  memo.Remember("", 7);
  EXPECT_EQ(memo.Find(""), nullptr);
  EXPECT_EQ(memo.size(), 0u);
}

TEST(RequestMemoTest, ForgetsTheOldestPastItsCapacity) {
  RequestMemo<std::string> memo(/*capacity=*/3);
  for (int i = 0; i < 5; ++i) {
    const auto evicted = memo.Remember(absl::StrCat("r", i), absl::StrCat("m", i));
    // Each id past the third pushes out the oldest, and says which.
    if (i < 3) {
      EXPECT_FALSE(evicted.has_value()) << i;
    } else {
      ASSERT_TRUE(evicted.has_value()) << i;
      EXPECT_EQ(evicted->first, absl::StrCat("r", i - 3));
      EXPECT_EQ(evicted->second, absl::StrCat("m", i - 3));
    }
  }
  EXPECT_EQ(memo.size(), 3u);
  EXPECT_EQ(memo.Find("r0"), nullptr);
  EXPECT_EQ(memo.Find("r1"), nullptr);
  ASSERT_NE(memo.Find("r4"), nullptr);
  EXPECT_EQ(*memo.Find("r2"), "m2");
  EXPECT_EQ(RequestMemo<int>::kDefaultCapacity, 4096u);
}

// The bytes a mission's remembered answers hold: at least their ids, which
// the memo keeps twice (its map and its order); flat once the capacity is
// reached, as the oldest go; unchanged by a retry of a known id; grown by a
// plan's answer by at least the waypoints it holds.
TEST(IdempotencyMemoTest, ItsBytesStayFlatOnceOldIdsArePushedOut) {
  IdempotencyMemo memo;
  EXPECT_EQ(memo.bytes(), 0);
  const std::string padding(1000, 'x');
  auto id = [&](int i) { return absl::StrFormat("%06d", i) + padding; };
  constexpr int kCapacity = static_cast<int>(RequestMemo<int>::kDefaultCapacity);
  for (int i = 0; i < kCapacity; ++i) memo.Remember({id(i), "f"}, MeasurementResult{});
  const std::int64_t full = memo.bytes();
  EXPECT_GE(full, std::int64_t{kCapacity} * 2 * 1006);
  for (int i = kCapacity; i < kCapacity + 900; ++i) {
    memo.Remember({id(i), "f"}, MeasurementResult{});
  }
  EXPECT_EQ(memo.bytes(), full);
  memo.Remember({id(kCapacity + 10), "f"}, MeasurementResult{.cells_fused = 9});
  EXPECT_EQ(memo.bytes(), full);
  PlannedPath path{.trajectory = *PolynomialTrajectory::FromCoefficients(
                       {1.0}, {PolynomialTrajectory::SegmentCoefficients::Zero()})};
  path.control_waypoints_W.assign(100, Vec3::Zero());
  memo.Remember({id(kCapacity + 900), "f"}, path);  // pushes out one 1006-byte id
  EXPECT_GE(memo.bytes(), full + static_cast<std::int64_t>(100 * sizeof(Vec3)));
}

}  // namespace
}  // namespace oaipp::server
