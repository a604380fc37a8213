// The MissionStore contract, against both backends for real: a SQLite file
// in a temporary folder, and a PostgreSQL server the suite starts itself
// (initdb in a temporary folder, loopback only; each test gets its own
// database). Numbers never repeat, records come back byte for byte and in
// order, appends are conditional on (mission, sequence) and a retry of the
// same record succeeds, snapshots replace the records they cover, deletes
// cascade, and many missions can append at once.
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <tuple>

#include <pqxx/pqxx>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"
#include "server/store/open_store.h"
#include "server/store/postgres_schema.h"
#include "server/store/postgres_store.h"
#include "server/store/sqlite_store.h"
#include "tests/server/postgres_instance.h"

namespace oaipp::server {
namespace {

// The parameter: "sqlite" or "postgresql".
class StoreTest : public ::testing::TestWithParam<std::string> {
 protected:
  static void SetUpTestSuite() {
    if (testing::PostgresInstance::Available()) {
      postgres_ = new testing::PostgresInstance();
      if (!postgres_->Start()) {
        delete postgres_;
        postgres_ = nullptr;
      }
    }
  }
  static void TearDownTestSuite() {
    delete postgres_;
    postgres_ = nullptr;
  }

  void SetUp() override {
    const std::string test = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    dir_ = std::filesystem::temp_directory_path() / absl::StrCat("oaipp-store-", getpid());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    if (GetParam() == "postgresql") {
      if (postgres_ == nullptr) {
        if (std::getenv("OAIPP_REQUIRE_POSTGRES") != nullptr) {
          FAIL() << "PostgreSQL 15 is not installed or did not start";
        }
        GTEST_SKIP() << "PostgreSQL 15 is not installed";
      }
      const std::string database = absl::StrCat("t", ++databases_);
      ASSERT_TRUE(postgres_->CreateDatabase(database));
      uri_ = postgres_->uri(database);
    }
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::unique_ptr<MissionStore> Open() {
    absl::StatusOr<std::unique_ptr<MissionStore>> store =
        GetParam() == "sqlite" ? OpenSqliteStore((dir_ / "missions.db").string())
                               : OpenPostgresStore(uri_);
    EXPECT_TRUE(store.ok()) << store.status();
    return store.ok() ? *std::move(store) : nullptr;
  }

  static testing::PostgresInstance* postgres_;
  static int databases_;
  std::filesystem::path dir_;
  std::string uri_;
};

testing::PostgresInstance* StoreTest::postgres_ = nullptr;
int StoreTest::databases_ = 0;

INSTANTIATE_TEST_SUITE_P(Backends, StoreTest, ::testing::Values("sqlite", "postgresql"),
                         [](const auto& param_info) { return param_info.param; });

LogRecord Record(std::int64_t sequence, std::string payload) {
  return {.sequence = sequence,
          .kind = RecordKind::kMeasurement,
          .payload = std::move(payload),
          .request_id = absl::StrCat("r", sequence),
          .fingerprint = "f"};
}

TEST_P(StoreTest, MissionNumbersNeverRepeatAcrossReopening) {
  {
    std::unique_ptr<MissionStore> store = Open();
    EXPECT_EQ(*store->NextMissionNumber(), 1);
    EXPECT_EQ(*store->NextMissionNumber(), 2);
  }
  std::unique_ptr<MissionStore> store = Open();
  EXPECT_EQ(*store->NextMissionNumber(), 3);
}

// A listing holds the missions under one prefix (a tenant's) and none below
// a further '/', in creation order, then by id where two were created in
// the same microsecond, and resumes after any position; the expected order
// is written out here, not computed.
TEST_P(StoreTest, AListingGoesInCreationOrderUnderOnePrefix) {
  std::unique_ptr<MissionStore> store = Open();
  const std::vector<std::pair<std::string, std::int64_t>> created = {
      {"a/m3", 30}, {"a/m1", 10},   {"b/m2", 20}, {"a/m2", 20},
      {"m9", 5},    {"a/x/m4", 15}, {"a/m0", 20}, {"ab/m5", 12}};
  for (const auto& [id, time] : created) {
    ASSERT_TRUE(
        store->CreateMission({.id = id, .spec = "spec of " + id, .create_time_unix_us = time})
            .ok());
  }
  auto ids = [&](const std::string& prefix, std::int64_t t, const std::string& after, int limit) {
    absl::StatusOr<std::vector<MissionListing>> listed = store->List(prefix, t, after, limit);
    EXPECT_TRUE(listed.ok()) << listed.status();
    std::vector<std::string> out;
    for (const MissionListing& m : listed.value_or(std::vector<MissionListing>{})) {
      EXPECT_EQ(m.spec, "spec of " + m.id);
      out.push_back(m.id);
    }
    return out;
  };
  using Ids = std::vector<std::string>;
  EXPECT_EQ(ids("a/", 0, "", 10), (Ids{"a/m1", "a/m0", "a/m2", "a/m3"}));
  EXPECT_EQ(ids("a/", 0, "", 2), (Ids{"a/m1", "a/m0"}));
  EXPECT_EQ(ids("a/", 20, "a/m0", 10), (Ids{"a/m2", "a/m3"}));
  EXPECT_EQ(ids("a/", 30, "a/m3", 10), Ids{});
  EXPECT_EQ(ids("b/", 0, "", 10), Ids{"b/m2"});
  // No prefix: only ids without a '/' (missions of no tenant).
  EXPECT_EQ(ids("", 0, "", 10), Ids{"m9"});
  absl::StatusOr<std::vector<MissionListing>> timed = store->List("a/", 0, "", 1);
  ASSERT_TRUE(timed.ok() && timed->size() == 1u);
  EXPECT_EQ(timed->front().create_time_unix_us, 10);
}

// The signing key is made once and kept: the same after reopening, and for
// a second store object on the same database (another server).
TEST_P(StoreTest, TheSigningKeyIsMadeOnceAndShared) {
  std::string first;
  {
    std::unique_ptr<MissionStore> store = Open();
    absl::StatusOr<std::string> key = store->SigningKey();
    ASSERT_TRUE(key.ok()) << key.status();
    EXPECT_EQ(key->size(), 32u);
    first = *key;
  }
  std::unique_ptr<MissionStore> store = Open();
  EXPECT_EQ(*store->SigningKey(), first);
  if (GetParam() == "postgresql") {  // SQLite has one server per file
    std::unique_ptr<MissionStore> other = Open();
    EXPECT_EQ(*other->SigningKey(), first);
  }
  EXPECT_NE(first, std::string(32, '\0'));
}

// One holder at a time: a lease is taken when free, renewed by its holder,
// refused to another until it expires, then taken by the other.
TEST_P(StoreTest, ALeaseHasOneHolderUntilItExpires) {
  std::unique_ptr<MissionStore> store = Open();
  auto lease = [&](const std::string& holder, std::int64_t now, std::int64_t until) {
    absl::StatusOr<bool> held = store->TryLease("retention", holder, now, until, false);
    EXPECT_TRUE(held.ok()) << held.status();
    return held.value_or(false);
  };
  EXPECT_TRUE(lease("a", 100, 200));
  EXPECT_FALSE(lease("b", 150, 250));  // a's until 200
  EXPECT_TRUE(lease("a", 190, 300));   // renewed
  EXPECT_FALSE(lease("b", 250, 350));  // still a's
  EXPECT_TRUE(lease("b", 301, 400));   // lapsed at 300
  EXPECT_FALSE(lease("a", 302, 500));
  absl::StatusOr<bool> other = store->TryLease("another job", "a", 302, 500, false);
  ASSERT_TRUE(other.ok());
  EXPECT_TRUE(*other);  // leases are per name
}

// Asked with free_if_holder_silent, a lease is also free when its holder is
// not alive: it never said so, its heartbeat's time has passed, or it
// retired (which also frees its leases for everyone).
TEST_P(StoreTest, ALeaseOfASilentHolderIsFreeToThoseWhoAskSo) {
  std::unique_ptr<MissionStore> store = Open();
  auto lease = [&](const std::string& holder, std::int64_t now, bool silent,
                   const std::string& name = "mission/m") {
    absl::StatusOr<bool> held = store->TryLease(name, holder, now, now + 1000, silent);
    EXPECT_TRUE(held.ok()) << held.status();
    return held.value_or(false);
  };
  EXPECT_EQ(*store->LeaseHolderAliveUntil("mission/m"), 0);  // nobody holds it
  ASSERT_TRUE(store->Heartbeat("a", 500, 0).ok());
  EXPECT_TRUE(lease("a", 100, true));  // a's until 1100, a alive until 500
  EXPECT_EQ(*store->LeaseHolderAliveUntil("mission/m"), 500);
  EXPECT_FALSE(lease("b", 200, true));   // a is alive
  EXPECT_FALSE(lease("b", 600, false));  // a is silent, but b did not ask for that
  EXPECT_TRUE(lease("b", 600, true));    // a is silent: b's until 1600
  EXPECT_EQ(*store->LeaseHolderAliveUntil("mission/m"), 0);  // b never said it is alive
  ASSERT_TRUE(store->Heartbeat("a", 2000, 0).ok());
  ASSERT_TRUE(store->Heartbeat("b", 2000, 0).ok());
  EXPECT_FALSE(lease("a", 700, true));  // b is alive and its lease runs
  EXPECT_EQ(*store->LeaseHolderAliveUntil("mission/m"), 2000);
  EXPECT_TRUE(lease("a", 1700, true));  // b's lease lapsed at 1600
  ASSERT_TRUE(store->Retire("a").ok());
  EXPECT_TRUE(lease("b", 1800, false));  // a retired: its lease is gone
  EXPECT_TRUE(lease("c", 1800, false, "mission/n"));
  EXPECT_FALSE(lease("b", 1900, false, "mission/n"));
  EXPECT_TRUE(lease("b", 1900, true, "mission/n"));  // c never said it is alive
  EXPECT_FALSE(lease("c", 2000, false, "mission/n"));
  ASSERT_TRUE(store->ForgetDeletionsBefore(3000).ok());  // b's lease lapses at 2900
  EXPECT_TRUE(lease("c", 2000, false, "mission/n"));     // forgotten
}

// What a standby reads (View): the live servers with their ring ids, and
// each mission whose lease a live server holds (lapsed or not), with its
// last stored sequence, its snapshot's when no record follows it; and
// LoadAfter, which leaves out what the reader has.
TEST_P(StoreTest, TheViewListsLiveServersAndTheMissionsTheyHold) {
  std::unique_ptr<MissionStore> store = Open();
  const std::string second("t/m\0\xff", 5);
  for (const std::string& id : {std::string("m1"), second, std::string("m3")}) {
    ASSERT_TRUE(store->CreateMission({.id = id, .spec = "s"}).ok());
  }
  for (int i = 1; i <= 4; ++i) ASSERT_TRUE(store->Append("m1", Record(i, "x")).ok());
  for (int i = 1; i <= 2; ++i) ASSERT_TRUE(store->Append("m3", Record(i, "x")).ok());
  ASSERT_TRUE(store->PutSnapshot("m3", {.sequence = 2, .state = "s2"}).ok());
  ASSERT_TRUE(store->Heartbeat("a", 1000, 3).ok());
  ASSERT_TRUE(store->Heartbeat("b", 1000, 0).ok());
  ASSERT_TRUE(store->Heartbeat("c", 100, 2).ok());  // silent at 500
  for (const auto& [id, holder] : std::vector<std::pair<std::string, std::string>>{
           {"m1", "a"}, {second, "b"}, {"m3", "a"}, {"gone", "a"}}) {
    ASSERT_TRUE(*store->TryLease(absl::StrCat("mission/", absl::BytesToHexString(id)), holder, 0,
                                 200, false));
  }
  ASSERT_TRUE(*store->TryLease("mission/not-hex", "a", 0, 200, false));
  ASSERT_TRUE(*store->TryLease("retention", "a", 0, 200, false));

  absl::StatusOr<StoreView> view = store->View("mission/", 500);
  ASSERT_TRUE(view.ok()) << view.status();
  ASSERT_EQ(view->alive.size(), 2u);
  EXPECT_EQ(view->alive[0].holder, "a");
  EXPECT_EQ(view->alive[0].ring_id, 3);
  EXPECT_EQ(view->alive[1].holder, "b");
  EXPECT_EQ(view->alive[1].ring_id, 0);
  // holder, alive, ring id, last sequence
  using Seen = std::tuple<std::string, bool, int, std::int64_t>;
  const auto held_in = [](const StoreView& v) {
    std::map<std::string, Seen> held;
    for (const StoreView::Held& h : v.held) {
      held[h.mission_id] = {h.holder, h.holder_alive, h.holder_ring_id, h.last_sequence};
    }
    return held;
  };
  std::map<std::string, Seen> held = held_in(*view);
  EXPECT_EQ(held.size(), 3u);  // no lease of a deleted mission, nor another kind
  EXPECT_EQ(held["m1"], Seen("a", true, 3, 4));
  EXPECT_EQ(held[second], Seen("b", true, 0, 0));
  EXPECT_EQ(held["m3"], Seen("a", true, 3, 2));

  // "a" and "b" fall silent: their missions are listed, their holders not
  // alive.
  view = store->View("mission/", 1500);
  ASSERT_TRUE(view.ok()) << view.status();
  EXPECT_TRUE(view->alive.empty());
  held = held_in(*view);
  EXPECT_EQ(held.size(), 3u);
  EXPECT_EQ(held["m1"], Seen("a", false, 3, 4));

  absl::StatusOr<StoredMission> after = store->LoadAfter("m1", 2);
  ASSERT_TRUE(after.ok()) << after.status();
  ASSERT_EQ(after->log.size(), 2u);
  EXPECT_EQ(after->log[0].sequence, 3);
  after = store->LoadAfter("m3", 1);  // the snapshot at 2 is later than what it has
  ASSERT_TRUE(after.ok()) << after.status();
  ASSERT_TRUE(after->snapshot.has_value());
  EXPECT_EQ(after->snapshot->state, "s2");
  after = store->LoadAfter("m3", 2);
  ASSERT_TRUE(after.ok()) << after.status();
  EXPECT_FALSE(after->snapshot.has_value());
  EXPECT_TRUE(after->log.empty());
  EXPECT_EQ(store->LoadAfter("nobody", 0).status().code(), absl::StatusCode::kNotFound);
}

// A mission is idle since a time when it was created before it and nothing
// (record or snapshot) was written to it since; the times are written out.
TEST_P(StoreTest, IdleMissionsAreThoseNothingWasWrittenToSince) {
  std::unique_ptr<MissionStore> store = Open();
  for (const auto& [id, created] : std::vector<std::pair<std::string, std::int64_t>>{
           {"old", 10}, {"written", 10}, {"snapshotted", 10}, {"new", 60}}) {
    ASSERT_TRUE(store->CreateMission({.id = id, .spec = "s", .create_time_unix_us = created}).ok());
  }
  LogRecord late = Record(1, "late");
  late.write_time_unix_us = 70;
  ASSERT_TRUE(store->Append("written", late).ok());
  LogRecord early = Record(1, "early");
  early.write_time_unix_us = 20;
  ASSERT_TRUE(store->Append("old", early).ok());
  LogRecord covered = Record(1, "covered");
  covered.write_time_unix_us = 20;
  ASSERT_TRUE(store->Append("snapshotted", covered).ok());
  ASSERT_TRUE(
      store->PutSnapshot("snapshotted", {.sequence = 1, .state = "x", .write_time_unix_us = 80})
          .ok());
  absl::StatusOr<std::vector<std::pair<std::string, std::int64_t>>> idle = store->IdleSince(50, 10);
  ASSERT_TRUE(idle.ok()) << idle.status();
  ASSERT_EQ(idle->size(), 1u);
  EXPECT_EQ(idle->front().first, "old");
  EXPECT_EQ(idle->front().second, kFirstEpoch);
  idle = store->IdleSince(100, 10);
  ASSERT_TRUE(idle.ok());
  EXPECT_EQ(idle->size(), 4u);
  idle = store->IdleSince(100, 2);
  ASSERT_TRUE(idle.ok());
  EXPECT_EQ(idle->size(), 2u);
}

TEST_P(StoreTest, RecordsComeBackInOrderByteForByte) {
  std::string every_byte;
  for (int b = 0; b < 256; ++b) every_byte.push_back(static_cast<char>(b));
  {
    std::unique_ptr<MissionStore> store = Open();
    ASSERT_TRUE(store->CreateMission({.id = "m1", .spec = every_byte, .request_id = "c1"}).ok());
    ASSERT_TRUE(store->Append("m1", Record(1, "one")).ok());
    LogRecord plan = Record(2, every_byte);
    plan.kind = RecordKind::kPlan;
    plan.result = every_byte + "answer";
    plan.planner_state = std::string("7\0", 2);
    plan.write_time_unix_us = 1234567;
    ASSERT_TRUE(store->Append("m1", plan).ok());
  }
  std::unique_ptr<MissionStore> store = Open();
  absl::StatusOr<std::vector<StoredMission>> all = store->LoadAll();
  ASSERT_TRUE(all.ok()) << all.status();
  ASSERT_EQ(all->size(), 1u);
  const StoredMission& m = all->front();
  EXPECT_EQ(m.id, "m1");
  EXPECT_EQ(m.spec, every_byte);
  EXPECT_EQ(m.request_id, "c1");
  EXPECT_FALSE(m.snapshot.has_value());
  ASSERT_EQ(m.log.size(), 2u);
  EXPECT_EQ(m.log[0].sequence, 1);
  EXPECT_EQ(m.log[0].payload, "one");
  EXPECT_EQ(m.log[0].request_id, "r1");
  EXPECT_GT(m.log[0].write_time_unix_us, 1'700'000'000'000'000);  // the clock's, when unset
  EXPECT_EQ(m.log[1].kind, RecordKind::kPlan);
  EXPECT_EQ(m.log[1].payload, every_byte);
  EXPECT_EQ(m.log[1].result, every_byte + "answer");
  EXPECT_EQ(m.log[1].planner_state, std::string("7\0", 2));
  EXPECT_EQ(m.log[1].write_time_unix_us, 1234567);
}

TEST_P(StoreTest, AppendsAreConditionalAndARetryOfTheSameRecordSucceeds) {
  std::unique_ptr<MissionStore> store = Open();
  ASSERT_TRUE(store->CreateMission({.id = "m1", .spec = "s"}).ok());
  ASSERT_TRUE(store->Append("m1", Record(1, "first")).ok());
  // The same request again (its first write's outcome was in doubt): OK,
  // and stored once.
  EXPECT_TRUE(store->Append("m1", Record(1, "first")).ok());
  // A second writer of sequence 1 (a stale owner, a double apply) is refused.
  EXPECT_EQ(store->Append("m1", Record(1, "again")).code(), absl::StatusCode::kAlreadyExists);
  LogRecord other_request = Record(1, "first");
  other_request.request_id = "someone-else";
  EXPECT_EQ(store->Append("m1", other_request).code(), absl::StatusCode::kAlreadyExists);
  EXPECT_EQ(store->Append("nobody", Record(1, "x")).code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(store->CreateMission({.id = "m1", .spec = "s"}).code(),
            absl::StatusCode::kAlreadyExists);
  absl::StatusOr<StoredMission> m = store->Load("m1");
  ASSERT_TRUE(m.ok()) << m.status();
  ASSERT_EQ(m->log.size(), 1u);
  EXPECT_EQ(m->log[0].payload, "first");
  EXPECT_EQ(store->Load("nobody").status().code(), absl::StatusCode::kNotFound);
}

TEST_P(StoreTest, ASnapshotReplacesTheRecordsItCovers) {
  std::unique_ptr<MissionStore> store = Open();
  ASSERT_TRUE(store->CreateMission({.id = "m1", .spec = "s"}).ok());
  for (int i = 1; i <= 5; ++i) ASSERT_TRUE(store->Append("m1", Record(i, "x")).ok());
  // Every byte value, NULs among them, and megabytes, as a map's snapshot
  // is: it must come back byte for byte whatever format carries it.
  std::string state("state\0\xff", 7);
  for (int i = 0; i < (1 << 20); ++i)
    state.push_back(static_cast<char>((i * 131 + i / 256) & 0xff));
  ASSERT_TRUE(store->PutSnapshot("m1", {.sequence = 3, .state = state}).ok());
  // An older snapshot (a slow writer) does not replace a newer one.
  ASSERT_TRUE(store->PutSnapshot("m1", {.sequence = 2, .state = "old"}).ok());
  EXPECT_EQ(store->PutSnapshot("nobody", {.sequence = 1, .state = "s"}).code(),
            absl::StatusCode::kNotFound);
  // A sequence the snapshot covers cannot be written again.
  EXPECT_EQ(store->Append("m1", Record(3, "x")).code(), absl::StatusCode::kAlreadyExists);
  ASSERT_TRUE(store->Append("m1", Record(6, "y")).ok());
  store.reset();
  store = Open();
  absl::StatusOr<StoredMission> m = store->Load("m1");
  ASSERT_TRUE(m.ok()) << m.status();
  ASSERT_TRUE(m->snapshot.has_value());
  EXPECT_EQ(m->snapshot->sequence, 3);
  EXPECT_EQ(m->snapshot->state, state);
  EXPECT_GT(m->snapshot->write_time_unix_us, 0);
  ASSERT_EQ(m->log.size(), 3u);
  EXPECT_EQ(m->log[0].sequence, 4);
  EXPECT_EQ(m->log[2].sequence, 6);
  // LoadAll gives the same.
  absl::StatusOr<std::vector<StoredMission>> all = store->LoadAll();
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all->size(), 1u);
  EXPECT_EQ(all->front().log.size(), 3u);
  EXPECT_EQ(all->front().snapshot->sequence, 3);
}

TEST_P(StoreTest, DeleteRemovesEverythingAndRemembersTheRequest) {
  std::unique_ptr<MissionStore> store = Open();
  ASSERT_TRUE(store->CreateMission({.id = "m1", .spec = "s", .create_time_unix_us = 1}).ok());
  ASSERT_TRUE(store->CreateMission({.id = "m2", .spec = "s", .create_time_unix_us = 2}).ok());
  ASSERT_TRUE(store->Append("m1", Record(1, "x")).ok());
  ASSERT_TRUE(store->PutSnapshot("m1", {.sequence = 1, .state = "s"}).ok());
  ASSERT_TRUE(store->DeleteMission("m1", "del-1", kFirstEpoch).ok());
  EXPECT_EQ(store->DeleteMission("m1", "del-2", kFirstEpoch).code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(*store->DeletedBy("del-1"), "m1");
  EXPECT_EQ(store->DeletedBy("del-2").status().code(), absl::StatusCode::kNotFound);
  // The id is free again and starts afresh: no records, no snapshot.
  ASSERT_TRUE(store->CreateMission({.id = "m1", .spec = "t", .create_time_unix_us = 3}).ok());
  ASSERT_TRUE(store->Append("m1", Record(1, "y")).ok());
  absl::StatusOr<std::vector<StoredMission>> all = store->LoadAll();
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all->size(), 2u);
  EXPECT_EQ((*all)[0].id, "m2");  // by creation time
  EXPECT_TRUE((*all)[0].log.empty());
  EXPECT_EQ((*all)[1].id, "m1");
  ASSERT_EQ((*all)[1].log.size(), 1u);
  EXPECT_EQ((*all)[1].log[0].payload, "y");
  EXPECT_FALSE((*all)[1].snapshot.has_value());
  // Retention forgets old deletions' request_ids.
  ASSERT_TRUE(store->ForgetDeletionsBefore(1).ok());
  EXPECT_TRUE(store->DeletedBy("del-1").ok());
  ASSERT_TRUE(store->ForgetDeletionsBefore(std::numeric_limits<std::int64_t>::max()).ok());
  EXPECT_EQ(store->DeletedBy("del-1").status().code(), absl::StatusCode::kNotFound);
  EXPECT_TRUE(store->Health().ok());
}

// Ownership: a claim raises the epoch and returns everything written so
// far; from then on, every kind of write from the old epoch is refused with
// kFenced and changes nothing, and the new owner writes on.
TEST_P(StoreTest, AClaimFencesEveryWriteOfTheOldOwner) {
  std::unique_ptr<MissionStore> store = Open();
  ASSERT_TRUE(
      store->CreateMission({.id = "m1", .spec = "s", .request_id = "c1", .fingerprint = "fc"})
          .ok());
  EXPECT_EQ(*store->Epoch("m1"), kFirstEpoch);
  ASSERT_TRUE(store->Append("m1", Record(1, "old owner")).ok());

  absl::StatusOr<StoredMission> claimed = store->Claim("m1", 0);
  ASSERT_TRUE(claimed.ok()) << claimed.status();
  EXPECT_EQ(claimed->epoch, kFirstEpoch + 1);
  EXPECT_EQ(*store->Epoch("m1"), kFirstEpoch + 1);
  ASSERT_EQ(claimed->log.size(), 1u);
  EXPECT_EQ(claimed->log[0].payload, "old owner");
  EXPECT_EQ(claimed->spec, "s");

  // The old owner, still at epoch 1, writes the next record: refused.
  const absl::Status stale = store->Append("m1", Record(2, "stale"));
  EXPECT_EQ(stale.code(), absl::StatusCode::kAborted) << stale;
  EXPECT_TRUE(stale.GetPayload(kFenced).has_value());
  const absl::Status stale_snapshot = store->PutSnapshot("m1", {.sequence = 1, .state = "x"});
  EXPECT_TRUE(stale_snapshot.GetPayload(kFenced).has_value()) << stale_snapshot;
  const absl::Status stale_delete = store->DeleteMission("m1", "del", kFirstEpoch);
  EXPECT_TRUE(stale_delete.GetPayload(kFenced).has_value()) << stale_delete;
  EXPECT_EQ(store->DeletedBy("del").status().code(), absl::StatusCode::kNotFound);

  // The new owner's writes go through at its epoch.
  LogRecord next = Record(2, "new owner");
  next.epoch = claimed->epoch;
  ASSERT_TRUE(store->Append("m1", next).ok());
  ASSERT_TRUE(
      store->PutSnapshot("m1", {.sequence = 2, .state = "st", .epoch = claimed->epoch}).ok());

  // A second claim (a third server) sees both owners' records, via the
  // snapshot, and fences the second owner in turn.
  absl::StatusOr<StoredMission> again = store->Claim("m1", 0);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(again->epoch, kFirstEpoch + 2);
  ASSERT_TRUE(again->snapshot.has_value());
  EXPECT_EQ(again->snapshot->sequence, 2);
  EXPECT_TRUE(again->log.empty());
  LogRecord late = Record(3, "second owner, late");
  late.epoch = claimed->epoch;
  EXPECT_TRUE(store->Append("m1", late).GetPayload(kFenced).has_value());

  // What a create's request_id made can be found from any server.
  absl::StatusOr<StoredMission> created = store->CreatedBy("c1");
  ASSERT_TRUE(created.ok()) << created.status();
  EXPECT_EQ(created->id, "m1");
  EXPECT_EQ(created->fingerprint, "fc");
  EXPECT_EQ(created->epoch, kFirstEpoch + 2);
  EXPECT_EQ(store->CreatedBy("c2").status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(store->Claim("nope", 0).status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(store->Epoch("nope").status().code(), absl::StatusCode::kNotFound);

  ASSERT_TRUE(store->DeleteMission("m1", "del", again->epoch).ok());
  EXPECT_EQ(*store->DeletedBy("del"), "m1");
}

// A claim by a reader that already holds the mission through a record
// leaves out what it holds: the snapshot unless a later one was stored, and
// the records up to that one. Put together, the reader has what a whole
// claim gives.
TEST_P(StoreTest, AClaimLeavesOutWhatTheReaderHolds) {
  std::unique_ptr<MissionStore> store = Open();
  ASSERT_TRUE(store->CreateMission({.id = "m1", .spec = "s"}).ok());
  for (int i = 1; i <= 3; ++i) ASSERT_TRUE(store->Append("m1", Record(i, "x")).ok());
  const std::string state(1 << 16, '\x7f');
  ASSERT_TRUE(store->PutSnapshot("m1", {.sequence = 2, .state = state}).ok());
  for (int i = 4; i <= 6; ++i) ASSERT_TRUE(store->Append("m1", Record(i, "y")).ok());

  // Held through record 4 (the snapshot at 2, then records 3 and 4):
  // records 5 and 6, no snapshot.
  absl::StatusOr<StoredMission> after = store->Claim("m1", 4);
  ASSERT_TRUE(after.ok()) << after.status();
  EXPECT_EQ(after->epoch, kFirstEpoch + 1);
  EXPECT_EQ(after->spec, "s");
  EXPECT_FALSE(after->snapshot.has_value());
  ASSERT_EQ(after->log.size(), 2u);
  EXPECT_EQ(after->log[0].sequence, 5);
  EXPECT_EQ(after->log[1].sequence, 6);

  // Held through record 1 only, and the snapshot covers 2: the snapshot
  // and the records after it, as a whole claim gives them.
  absl::StatusOr<StoredMission> behind = store->Claim("m1", 1);
  ASSERT_TRUE(behind.ok()) << behind.status();
  ASSERT_TRUE(behind->snapshot.has_value());
  EXPECT_EQ(behind->snapshot->sequence, 2);
  EXPECT_EQ(behind->snapshot->state, state);
  ASSERT_EQ(behind->log.size(), 4u);
  EXPECT_EQ(behind->log.front().sequence, 3);

  // Held through the last record: nothing to read but the mission itself.
  absl::StatusOr<StoredMission> all = store->Claim("m1", 6);
  ASSERT_TRUE(all.ok()) << all.status();
  EXPECT_EQ(all->epoch, kFirstEpoch + 3);
  EXPECT_FALSE(all->snapshot.has_value());
  EXPECT_TRUE(all->log.empty());
}

// Claims racing appends: whatever the interleaving, every append the store
// acknowledged is in what some claim returned or read after it, and no
// append is acknowledged at an epoch that was no longer current.
TEST_P(StoreTest, ClaimsRacingAppendsLoseNoAcknowledgedRecord) {
  std::unique_ptr<MissionStore> store = Open();
  ASSERT_TRUE(store->CreateMission({.id = "m1", .spec = "s"}).ok());
  std::atomic<std::int64_t> epoch{kFirstEpoch};
  std::atomic<bool> stop{false};
  std::mutex acked_mu;
  std::vector<std::int64_t> acked;
  // The writer appends at the epoch it last learnt; when fenced, it learns
  // the new one and reads the log's end from a fresh load.
  std::thread writer([&] {
    std::int64_t held = epoch.load();
    std::int64_t next = 1;
    for (int i = 0; i < 400 && !stop; ++i) {
      LogRecord r = Record(next, absl::StrCat("p", next));
      r.epoch = held;
      const absl::Status s = store->Append("m1", r);
      if (s.ok()) {
        std::lock_guard<std::mutex> lock(acked_mu);
        acked.push_back(next++);
      } else if (s.GetPayload(kFenced).has_value()) {
        absl::StatusOr<StoredMission> now = store->Load("m1");
        ASSERT_TRUE(now.ok());
        held = now->epoch;
        next = now->log.empty() ? 1 : now->log.back().sequence + 1;
      } else {
        ADD_FAILURE() << s;
        return;
      }
    }
  });
  for (int c = 0; c < 20; ++c) {
    // Everything acknowledged before the claim began is in what it returns.
    std::vector<std::int64_t> before;
    {
      std::lock_guard<std::mutex> lock(acked_mu);
      before = acked;
    }
    absl::StatusOr<StoredMission> claimed = store->Claim("m1", 0);
    ASSERT_TRUE(claimed.ok()) << claimed.status();
    epoch = claimed->epoch;
    std::set<std::int64_t> in_claim;
    for (const LogRecord& r : claimed->log) in_claim.insert(r.sequence);
    for (std::int64_t seq : before) EXPECT_TRUE(in_claim.contains(seq)) << "record " << seq;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  stop = true;
  writer.join();
  absl::StatusOr<StoredMission> final_state = store->Load("m1");
  ASSERT_TRUE(final_state.ok());
  ASSERT_EQ(final_state->log.size(), acked.size());
  for (std::size_t i = 0; i < acked.size(); ++i) {
    EXPECT_EQ(final_state->log[i].sequence, static_cast<std::int64_t>(i + 1));
    EXPECT_EQ(final_state->log[i].payload, absl::StrCat("p", i + 1));
  }
  EXPECT_EQ(final_state->epoch, kFirstEpoch + 20);
}

// A server opening a store that running servers use takes table locks for
// its (idempotent) schema that their transactions may hold in the other
// order. Here a transaction reads the missions table, the open waits for it
// while holding the schema lock, and the transaction then asks for that
// lock: PostgreSQL breaks the deadlock by rolling back the open, which
// waited first. The open is tried again and succeeds once the other commits.
TEST_P(StoreTest, AnOpenRolledBackByADeadlockIsTriedAgain) {
  if (GetParam() != "postgresql") GTEST_SKIP() << "a PostgreSQL deadlock";
  ASSERT_NE(Open(), nullptr);
  pqxx::connection other(uri_);
  pqxx::work held(other);
  held.exec("SELECT 1 FROM missions LIMIT 1");
  absl::StatusOr<std::unique_ptr<MissionStore>> reopened =
      absl::UnknownError("the open has not returned");
  std::thread opener([&] { reopened = OpenPostgresStore(uri_); });
  pqxx::connection watcher(uri_);
  bool waiting = false;
  for (int i = 0; i < 200 && !waiting; ++i) {
    pqxx::nontransaction query(watcher);
    waiting = query
                  .exec1(
                      "SELECT count(*) FROM pg_locks l JOIN pg_class c ON c.oid = l.relation "
                      "WHERE NOT l.granted AND c.relname = 'missions'")[0]
                  .as<int>() > 0;
    if (!waiting) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (!waiting) held.abort();
  ASSERT_TRUE(waiting) << "the open never waited for the missions table";
  held.exec_params("SELECT pg_advisory_xact_lock($1)", postgres::kSchemaLockKey);
  held.commit();
  opener.join();
  ASSERT_TRUE(reopened.ok()) << reopened.status();
  EXPECT_TRUE((*reopened)->Health().ok());
}

TEST_P(StoreTest, ManyMissionsAppendAtOnce) {
  std::unique_ptr<MissionStore> store = Open();
  constexpr int kMissions = 8, kRecords = 25;
  for (int m = 0; m < kMissions; ++m) {
    ASSERT_TRUE(store->CreateMission({.id = absl::StrCat("m", m), .spec = "s"}).ok());
  }
  std::vector<std::thread> writers;
  std::atomic<int> failures{0};
  for (int m = 0; m < kMissions; ++m) {
    writers.emplace_back([&, m] {
      for (int i = 1; i <= kRecords; ++i) {
        if (!store->Append(absl::StrCat("m", m), Record(i, absl::StrCat(m, ":", i))).ok()) {
          ++failures;
        }
      }
    });
  }
  for (std::thread& t : writers) t.join();
  EXPECT_EQ(failures.load(), 0);
  absl::StatusOr<std::vector<StoredMission>> all = store->LoadAll();
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all->size(), static_cast<std::size_t>(kMissions));
  for (const StoredMission& m : *all) {
    ASSERT_EQ(m.log.size(), static_cast<std::size_t>(kRecords)) << m.id;
    for (int i = 0; i < kRecords; ++i) {
      EXPECT_EQ(m.log[i].payload, absl::StrCat(m.id.substr(1), ":", i + 1));
    }
  }
}

TEST(SqliteStoreTest, AFolderThatDoesNotExistIsUnavailable) {
  absl::StatusOr<std::unique_ptr<MissionStore>> store =
      OpenSqliteStore("/nonexistent-oaipp/no/such/missions.db");
  EXPECT_EQ(store.status().code(), absl::StatusCode::kUnavailable);
}

TEST(OpenStoreTest, TheFlagNamesTheStoreAndLogsHideThePassword) {
  EXPECT_EQ(OpenStore("mysql://x", "/tmp").status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(*OpenStore("memory", "/tmp"), nullptr);
  const std::string shown = DescribeStore("postgresql://oaipp:s3cret@db:5432/missions", "");
  EXPECT_EQ(shown, "postgresql postgresql://oaipp:***@db:5432/missions");
  EXPECT_EQ(DescribeStore("postgresql://oaipp@db/missions", ""),
            "postgresql postgresql://oaipp@db/missions");
  EXPECT_EQ(DescribeStore("sqlite", "/var/lib/oaipp"), "sqlite file /var/lib/oaipp/missions.db");
  // A password in the query, a '@' in the password, an sslpassword.
  EXPECT_EQ(DescribeStore("postgresql://db/missions?user=a&password=s3cret&sslmode=require", ""),
            "postgresql postgresql://db/missions?user=a&password=***&sslmode=require");
  EXPECT_EQ(DescribeStore("postgres://a:p@ss@db/m?PASSWORD=x&sslpassword=y", ""),
            "postgresql postgres://a:***@db/m?PASSWORD=***&sslpassword=***");
}

// A --data_dir the store creates, and its database, are the owner's alone.
TEST(OpenStoreTest, ANewDataDirAndItsFilesAreTheOwnersOnly) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("oaipp-perms-" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  {
    absl::StatusOr<std::unique_ptr<MissionStore>> store = OpenStore("sqlite", (dir / "d").string());
    ASSERT_TRUE(store.ok()) << store.status();
    ASSERT_TRUE((*store)->CreateMission({.id = "m", .spec = "s"}).ok());
    using std::filesystem::perms;
    EXPECT_EQ(std::filesystem::status(dir / "d").permissions() & perms::all, perms::owner_all);
    for (const char* file : {"missions.db", "missions.db-wal"}) {
      ASSERT_TRUE(std::filesystem::exists(dir / "d" / file)) << file;
      EXPECT_EQ(std::filesystem::status(dir / "d" / file).permissions() & perms::all,
                perms::owner_read | perms::owner_write)
          << file;
    }
  }
  std::filesystem::remove_all(dir);
}

TEST(PostgresStoreTest, NoServerIsUnavailable) {
  // Port 1 on loopback: nothing listens there.
  absl::StatusOr<std::unique_ptr<MissionStore>> store =
      OpenPostgresStore("postgresql://postgres@127.0.0.1:1/postgres?connect_timeout=2");
  EXPECT_EQ(store.status().code(), absl::StatusCode::kUnavailable) << store.status();
}

}  // namespace
}  // namespace oaipp::server
