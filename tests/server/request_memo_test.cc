// The request_id memo behind every idempotent mutation: first result kept,
// empty ids never remembered, oldest forgotten past the capacity.
#include "server/request_memo.h"

#include <string>

#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"

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
  for (int i = 0; i < 5; ++i) memo.Remember(absl::StrCat("r", i), absl::StrCat("m", i));
  EXPECT_EQ(memo.size(), 3u);
  EXPECT_EQ(memo.Find("r0"), nullptr);
  EXPECT_EQ(memo.Find("r1"), nullptr);
  ASSERT_NE(memo.Find("r4"), nullptr);
  EXPECT_EQ(*memo.Find("r2"), "m2");
  EXPECT_EQ(RequestMemo<int>::kDefaultCapacity, 4096u);
}

}  // namespace
}  // namespace oaipp::server
