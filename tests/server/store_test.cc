// The SQLite mission store against a real file in a temporary folder:
// numbers never repeat, appends are conditional on (mission, sequence),
// deletes cascade, and everything survives closing and reopening.
#include "server/store/sqlite_store.h"

#include <filesystem>
#include <string>

#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"

namespace oaipp::server {
namespace {

class SqliteStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           absl::StrCat("oaipp-store-", ::testing::UnitTest::GetInstance()->random_seed(), "-",
                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::unique_ptr<MissionStore> Open() {
    absl::StatusOr<std::unique_ptr<MissionStore>> store =
        OpenSqliteStore((dir_ / "missions.db").string());
    EXPECT_TRUE(store.ok()) << store.status();
    return store.ok() ? *std::move(store) : nullptr;
  }
  std::filesystem::path dir_;
};

LogRecord Record(std::int64_t sequence, std::string payload) {
  return {.sequence = sequence,
          .kind = RecordKind::kMeasurement,
          .payload = std::move(payload),
          .request_id = absl::StrCat("r", sequence),
          .fingerprint = "f"};
}

TEST_F(SqliteStoreTest, MissionNumbersNeverRepeatAcrossReopening) {
  {
    std::unique_ptr<MissionStore> store = Open();
    EXPECT_EQ(*store->NextMissionNumber(), 1);
    EXPECT_EQ(*store->NextMissionNumber(), 2);
  }
  std::unique_ptr<MissionStore> store = Open();
  EXPECT_EQ(*store->NextMissionNumber(), 3);
}

TEST_F(SqliteStoreTest, RecordsComeBackInOrderByteForByte) {
  const std::string binary("a\0b\xff", 4);  // payloads are bytes, not text
  {
    std::unique_ptr<MissionStore> store = Open();
    ASSERT_TRUE(store->CreateMission({.id = "m1", .spec = binary, .request_id = "c1"}).ok());
    ASSERT_TRUE(store->Append("m1", Record(1, "one")).ok());
    LogRecord plan = Record(2, binary);
    plan.kind = RecordKind::kPlan;
    plan.result = "answer";
    plan.planner_state = "7";
    ASSERT_TRUE(store->Append("m1", plan).ok());
  }
  std::unique_ptr<MissionStore> store = Open();
  absl::StatusOr<std::vector<StoredMission>> all = store->LoadAll();
  ASSERT_TRUE(all.ok()) << all.status();
  ASSERT_EQ(all->size(), 1u);
  const StoredMission& m = all->front();
  EXPECT_EQ(m.id, "m1");
  EXPECT_EQ(m.spec, binary);
  EXPECT_EQ(m.request_id, "c1");
  ASSERT_EQ(m.log.size(), 2u);
  EXPECT_EQ(m.log[0].sequence, 1);
  EXPECT_EQ(m.log[0].payload, "one");
  EXPECT_EQ(m.log[0].request_id, "r1");
  EXPECT_EQ(m.log[1].kind, RecordKind::kPlan);
  EXPECT_EQ(m.log[1].payload, binary);
  EXPECT_EQ(m.log[1].result, "answer");
  EXPECT_EQ(m.log[1].planner_state, "7");
}

TEST_F(SqliteStoreTest, AppendsAreConditionalOnTheSequence) {
  std::unique_ptr<MissionStore> store = Open();
  ASSERT_TRUE(store->CreateMission({.id = "m1", .spec = "s"}).ok());
  ASSERT_TRUE(store->Append("m1", Record(1, "first")).ok());
  // A second writer of sequence 1 (a stale owner, a double apply) is refused.
  EXPECT_EQ(store->Append("m1", Record(1, "again")).code(), absl::StatusCode::kAlreadyExists);
  EXPECT_EQ(store->Append("nobody", Record(1, "x")).code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(store->CreateMission({.id = "m1", .spec = "s"}).code(),
            absl::StatusCode::kAlreadyExists);
  absl::StatusOr<std::vector<StoredMission>> all = store->LoadAll();
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all->front().log.size(), 1u);
  EXPECT_EQ(all->front().log[0].payload, "first");
}

TEST_F(SqliteStoreTest, DeleteRemovesTheRecordsAndRemembersTheRequest) {
  std::unique_ptr<MissionStore> store = Open();
  ASSERT_TRUE(store->CreateMission({.id = "m1", .spec = "s"}).ok());
  ASSERT_TRUE(store->CreateMission({.id = "m2", .spec = "s"}).ok());
  ASSERT_TRUE(store->Append("m1", Record(1, "x")).ok());
  ASSERT_TRUE(store->DeleteMission("m1", "del-1").ok());
  EXPECT_EQ(store->DeleteMission("m1", "del-2").code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(*store->DeletedBy("del-1"), "m1");
  EXPECT_EQ(store->DeletedBy("del-2").status().code(), absl::StatusCode::kNotFound);
  // The id is free again and starts a fresh log.
  ASSERT_TRUE(store->CreateMission({.id = "m1", .spec = "t"}).ok());
  ASSERT_TRUE(store->Append("m1", Record(1, "y")).ok());
  absl::StatusOr<std::vector<StoredMission>> all = store->LoadAll();
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all->size(), 2u);
  for (const StoredMission& m : *all) {
    if (m.id == "m1") {
      ASSERT_EQ(m.log.size(), 1u);
      EXPECT_EQ(m.log[0].payload, "y");
    } else {
      EXPECT_TRUE(m.log.empty());
    }
  }
  EXPECT_TRUE(store->Health().ok());
}

TEST_F(SqliteStoreTest, AFolderThatDoesNotExistIsUnavailable) {
  absl::StatusOr<std::unique_ptr<MissionStore>> store =
      OpenSqliteStore((dir_ / "no" / "such" / "missions.db").string());
  EXPECT_EQ(store.status().code(), absl::StatusCode::kUnavailable);
}

}  // namespace
}  // namespace oaipp::server
