// Two servers sharing one store (RegistryLimits::shared_store), in one
// process: a real SQLite store and two real services. Without a mission
// lease, a mission moves to the server that gets a call for it; the server
// it left has its next write refused (UNAVAILABLE, nothing applied) and
// lets go of its copy; a retry with the same request_id on the new owner is
// answered once; whatever either server acknowledged is in the map the
// other reads. With the lease (the default), a live holder keeps its
// mission and a call that reaches the other server rebuilds nothing.
#include <filesystem>
#include <thread>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "api/measurement.h"
#include "api/spec.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "server/registry.h"
#include "server/service_internal.h"
#include "server/store/sqlite_store.h"
#include "tests/server/service_fixture.h"

namespace oaipp::server {
namespace {

class TakeoverTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / absl::StrCat("oaipp-takeover-", getpid());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    absl::StatusOr<std::unique_ptr<MissionStore>> store =
        OpenSqliteStore((dir_ / "missions.db").string());
    ASSERT_TRUE(store.ok()) << store.status();
    store_ = *std::move(store);
    // No lease: the moves are what most of these tests check.
    StartBoth(absl::ZeroDuration());
  }
  void StartBoth(absl::Duration mission_lease) {
    a_.reset();
    b_.reset();
    const RegistryLimits shared{.max_missions = 8,
                                .max_cells_per_mission = 1600,
                                .shared_store = true,
                                .mission_lease = mission_lease};
    a_ = std::make_unique<testing::InProcessService>(shared, 1, 8, store_.get());
    b_ = std::make_unique<testing::InProcessService>(shared, 1, 8, store_.get());
  }
  void TearDown() override {
    a_.reset();
    b_.reset();
    store_.reset();
    std::filesystem::remove_all(dir_);
  }

  static grpc::Status Measure(testing::InProcessService& s, const std::string& request_id, double x,
                              v1::AddMeasurementResponse* out) {
    grpc::ClientContext c;
    v1::AddMeasurementRequest r = testing::LabelMeasurement("missions/m", x, 2.0, 8.0, x + 10,
                                                            /*target=*/x > 0);
    r.set_request_id(request_id);
    return s.stub().AddMeasurement(&c, r, out);
  }
  static v1::Mission Get(testing::InProcessService& s) {
    grpc::ClientContext c;
    v1::GetMissionRequest r;
    r.set_name("missions/m");
    v1::Mission out;
    EXPECT_TRUE(s.stub().GetMission(&c, r, &out).ok());
    return out;
  }

  std::filesystem::path dir_;
  std::unique_ptr<MissionStore> store_;
  std::unique_ptr<testing::InProcessService> a_, b_;
};

TEST_F(TakeoverTest, AMissionMovesToTheServerThatGetsItsCallsAndTheOldCopyIsFenced) {
  testing::CreateSmall(a_->stub(), "m");
  v1::AddMeasurementResponse out;
  ASSERT_TRUE(Measure(*a_, "r1", -3, &out).ok());
  ASSERT_TRUE(Measure(*a_, "r2", -1, &out).ok());
  EXPECT_EQ(a_->registry().size(), 1u);
  EXPECT_EQ(b_->registry().size(), 0u);  // a shared-store server loads nothing up front

  // B gets a call for the mission: it takes it over and sees A's writes.
  const v1::Mission on_b = Get(*b_);
  EXPECT_EQ(on_b.measurements_fused(), 2);
  EXPECT_EQ(b_->registry().takeovers(), 1);
  ASSERT_TRUE(Measure(*b_, "r3", 1, &out).ok());
  EXPECT_EQ(out.measurements_fused(), 3);

  // A still holds its old copy, without knowing. Its next write is refused
  // before anything is applied; A lets go of the copy.
  grpc::Status stale = Measure(*a_, "r4", 3, &out);
  // A checks the epoch before the write, so it takes the mission back
  // instead of writing from its old copy; the write then lands once.
  ASSERT_TRUE(stale.ok()) << stale.error_message();
  EXPECT_EQ(out.measurements_fused(), 4);
  EXPECT_EQ(a_->registry().takeovers(), 1);

  // B's copy is stale now: a retry of r3 there is answered once (it is in
  // the log B reads back), and B's own new write lands after A's.
  ASSERT_TRUE(Measure(*b_, "r3", 1, &out).ok());
  EXPECT_EQ(out.measurements_fused(), 3);  // the first answer to r3
  ASSERT_TRUE(Measure(*b_, "r5", 5, &out).ok());
  EXPECT_EQ(out.measurements_fused(), 5);

  // A's copy is stale; the sweep lets it go; B keeps its own.
  EXPECT_EQ(a_->registry().DropMoved(), std::vector<std::string>{"m"});
  EXPECT_EQ(a_->registry().size(), 0u);
  EXPECT_TRUE(b_->registry().DropMoved().empty());
  EXPECT_EQ(Get(*b_).measurements_fused(), 5);

  // The store's epoch: created at 1, claimed by B, A, B.
  EXPECT_EQ(*store_->Epoch("m"), kFirstEpoch + 3);
}

TEST_F(TakeoverTest, AWriteRacingATakeoverIsRefusedAndLeavesNothingBehind) {
  testing::CreateSmall(a_->stub(), "m");
  v1::AddMeasurementResponse out;
  ASSERT_TRUE(Measure(*a_, "r1", -3, &out).ok());
  absl::StatusOr<std::shared_ptr<Mission>> held = a_->registry().Get("missions/m");
  ASSERT_TRUE(held.ok());
  // B takes the mission between A's ownership check and A's write: A's
  // append is fenced by the store.
  ASSERT_EQ(Get(*b_).measurements_fused(), 1);
  const absl::Status refused = a_->registry().AfterFailedWrite(
      *held, store_->Append("m", {.sequence = 2,
                                  .kind = RecordKind::kMeasurement,
                                  .payload = "x",
                                  .epoch = (*held)->lease().epoch()}));
  EXPECT_EQ(refused.code(), absl::StatusCode::kUnavailable) << refused;
  EXPECT_NE(refused.message().find("another server"), absl::string_view::npos) << refused;
  EXPECT_EQ(a_->registry().size(), 0u);  // A let go of its copy
  absl::StatusOr<StoredMission> stored = store_->Load("m");
  ASSERT_TRUE(stored.ok());
  EXPECT_EQ(stored->log.size(), 1u);  // nothing of the refused write
  EXPECT_EQ(Get(*b_).measurements_fused(), 1);
}

TEST_F(TakeoverTest, ARetriedCreateThatReachesAnotherServerGetsTheFirstMission) {
  v1::CreateMissionRequest r;
  r.set_mission_id("m");
  r.set_request_id("create-1");
  *r.mutable_spec() = testing::SmallSpec();
  v1::Mission first, again;
  {
    grpc::ClientContext c;
    ASSERT_TRUE(a_->stub().CreateMission(&c, r, &first).ok());
  }
  {
    grpc::ClientContext c;
    ASSERT_TRUE(b_->stub().CreateMission(&c, r, &again).ok());  // the same request, on B
  }
  EXPECT_EQ(again.name(), "missions/m");
  EXPECT_EQ(b_->registry().takeovers(), 1);
  // A different request with that request_id is refused, naming it.
  r.mutable_spec()->set_budget_s(99);
  grpc::ClientContext c;
  const grpc::Status reused = b_->stub().CreateMission(&c, r, &again);
  EXPECT_EQ(reused.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(reused.error_message().find("request_id"), std::string::npos);
  // And a server-chosen id is never handed out twice across the servers.
  v1::CreateMissionRequest unnamed;
  *unnamed.mutable_spec() = testing::SmallSpec();
  v1::Mission x, y;
  grpc::ClientContext cx, cy;
  ASSERT_TRUE(a_->stub().CreateMission(&cx, unnamed, &x).ok());
  ASSERT_TRUE(b_->stub().CreateMission(&cy, unnamed, &y).ok());
  EXPECT_NE(x.name(), y.name());
}

TEST_F(TakeoverTest, DeletedOnOneServerIsGoneOnTheOther) {
  testing::CreateSmall(a_->stub(), "m");
  ASSERT_EQ(Get(*b_).name(), "missions/m");  // B took it over
  grpc::ClientContext c;
  v1::DeleteMissionRequest d;
  d.set_name("missions/m");
  d.set_request_id("del-1");
  v1::DeleteMissionResponse out;
  ASSERT_TRUE(a_->stub().DeleteMission(&c, d, &out).ok());  // A takes it back and deletes it
  grpc::ClientContext g;
  v1::GetMissionRequest r;
  r.set_name("missions/m");
  v1::Mission m;
  EXPECT_EQ(b_->stub().GetMission(&g, r, &m).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(b_->registry().size(), 0u);
  // The retry of the delete, on B: answered OK.
  grpc::ClientContext c2;
  EXPECT_TRUE(b_->stub().DeleteMission(&c2, d, &out).ok());
}

// With the lease: a call for A's mission that reaches B while A is alive
// (a forged or stale routing header) is refused after B has waited for A
// to fall silent, and B rebuilds nothing: the store's epoch stays. Once A
// stops (it retires from the store), B takes the mission at its next call.
TEST_F(TakeoverTest, ALiveHolderKeepsItsMissionUntilItStops) {
  StartBoth(RegistryLimits{}.mission_lease);
  testing::CreateSmall(a_->stub(), "m");
  v1::AddMeasurementResponse out;
  ASSERT_TRUE(Measure(*a_, "r1", -3, &out).ok());
  grpc::ClientContext c;
  v1::GetMissionRequest r;
  r.set_name("missions/m");
  v1::Mission m;
  const grpc::Status refused = b_->stub().GetMission(&c, r, &m);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_THAT(refused.error_message(), ::testing::HasSubstr("served by another server"));
  EXPECT_EQ(b_->registry().takeovers(), 0);
  EXPECT_EQ(b_->registry().size(), 0u);
  absl::StatusOr<std::int64_t> epoch = store_->Epoch("m");
  ASSERT_TRUE(epoch.ok());
  EXPECT_EQ(*epoch, kFirstEpoch);
  ASSERT_TRUE(Measure(*a_, "r2", -1, &out).ok());  // A serves on
  a_.reset();                                      // a graceful stop: A retires
  EXPECT_EQ(Get(*b_).measurements_fused(), 2);
  EXPECT_EQ(b_->registry().takeovers(), 1);
}

// A SQLite store in a folder of its own, removed with it: two or three
// registries share it, without servers, so that a test says when each one
// heartbeats and what it writes.
struct FolderStore {
  explicit FolderStore(const std::string& name)
      : dir(std::filesystem::temp_directory_path() / absl::StrCat(name, "-", getpid())) {
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    absl::StatusOr<std::unique_ptr<MissionStore>> opened =
        OpenSqliteStore((dir / "missions.db").string());
    EXPECT_TRUE(opened.ok()) << opened.status();
    if (opened.ok()) store = *std::move(opened);
  }
  ~FolderStore() {
    store.reset();
    std::filesystem::remove_all(dir);
  }
  std::filesystem::path dir;
  std::unique_ptr<MissionStore> store;
};

// Measurement k (request r<k>) of a mission as its holder applies and stores
// it, at x along the field.
void StoreMeasurement(MissionStore& store, Mission& mission, int k, double x) {
  v1::AddMeasurementRequest request =
      testing::LabelMeasurement("missions/" + mission.id(), x, 1.0, 8.0, 2.0 * k, k % 2);
  request.set_request_id(absl::StrCat("r", k));
  absl::StatusOr<MeasurementInput> input = api::MeasurementFromProto(request);
  ASSERT_TRUE(input.ok()) << input.status();
  const std::string fingerprint = absl::StrCat("f", k);
  ASSERT_TRUE(
      mission
          .AddMeasurement(*input, {request.request_id(), fingerprint},
                          service_internal::Recorder(&store, mission, RecordKind::kMeasurement,
                                                     request, fingerprint))
          .ok());
}

// A holder that dies (its heartbeats stop) while a call for its mission
// reaches another server: that server reads and rebuilds the mission while
// it waits for the holder to be found silent, then claims only what was
// written since, here a measurement the dying holder still stored after
// the early read. Two registries on one store, without servers, so that
// the test says when "a" heartbeats (once) and what it writes.
TEST(EarlyReadTest, ATakeoverReadsWhileItWaitsAndClaimsOnlyWhatCameSince) {
  FolderStore folder("oaipp-early-read");
  ASSERT_NE(folder.store, nullptr);
  MissionStore* const store = folder.store.get();
  // silent_after longer than a server's 500 ms, so that the steps below
  // keep their order under the sanitizers' slowness too.
  const RegistryLimits limits{.max_missions = 8,
                              .max_cells_per_mission = 1600,
                              .shared_store = true,
                              .silent_after = absl::Seconds(2)};
  RegistryLimits a_limits = limits, b_limits = limits;
  a_limits.holder = "a";
  b_limits.holder = "b";
  MissionRegistry a(a_limits, store), b(b_limits, store);

  // "a" creates the mission and stores three measurements.
  absl::StatusOr<api::MissionConfig> config = api::MissionSpecToConfig(testing::SmallSpec());
  ASSERT_TRUE(config.ok()) << config.status();
  absl::StatusOr<std::shared_ptr<Mission>> held = a.Create("m", *config, "create-m");
  ASSERT_TRUE(held.ok()) << held.status();
  const auto measure = [&](int k) { StoreMeasurement(*store, **held, k, -6.0 + 3 * k); };
  for (int k = 0; k < 3; ++k) measure(k);

  // "a" says once that it is alive for silent_after, and a call reaches
  // "b": "b" waits for "a" to fall silent, reading the mission once "a" has
  // missed two heartbeats (after 2/5 of silent_after). "a" stores one more
  // measurement after that (at 3/5), before it is found silent.
  ASSERT_TRUE(store->Heartbeat("a", absl::ToUnixMicros(absl::Now() + limits.silent_after), 0).ok());
  absl::StatusOr<std::shared_ptr<Mission>> taken;
  std::thread call([&] { taken = b.Get("missions/m"); });
  absl::SleepFor(limits.silent_after * 3 / 5);
  measure(3);
  call.join();
  ASSERT_TRUE(taken.ok()) << taken.status();
  EXPECT_EQ(b.takeovers(), 1);
  EXPECT_EQ((*taken)->lease().epoch(), kFirstEpoch + 1);

  // Everything "a" stored, in "b"'s copy: the same map, bit for bit.
  EXPECT_EQ((*taken)->Snapshot().measurements_fused, 4);
  EXPECT_EQ((*taken)->next_sequence(), (*held)->next_sequence());
  (*held)->ReadMap([&](const GpMap& want) {
    (*taken)->ReadMap([&](const GpMap& got) {
      EXPECT_EQ(got.Mean(), want.Mean());
      EXPECT_EQ(got.Covariance(), want.Covariance());
    });
  });
}

// Warm standbys: with three registries on one store, "a" (ring id 1) holds
// two missions that the proxies' ring sends to it while it lives; without
// it, the ring sends m-3 to ring id 3 and m-10 to ring id 2 (HashRingTest's
// routes, recorded from HAProxy), so "c" stands by for m-3 and "b" for
// m-10, each following what "a" stores. When
// "a" falls silent, "b" takes m-10 over from its standby, claiming only
// the record written after its last look, and ends with "a"'s map bit for
// bit.
TEST(StandbyTest, TheRingsSuccessorFollowsAMissionAndTakesItOverFromThere) {
  FolderStore folder("oaipp-standby");
  ASSERT_NE(folder.store, nullptr);
  MissionStore* const store = folder.store.get();
  std::vector<std::unique_ptr<MissionRegistry>> servers;
  for (int id = 1; id <= 3; ++id) {
    RegistryLimits limits{.max_missions = 8,
                          .max_cells_per_mission = 1600,
                          .shared_store = true,
                          .holder = std::string(1, static_cast<char>('a' + id - 1)),
                          .silent_after = absl::Seconds(1),
                          .ring_id = id};
    servers.push_back(std::make_unique<MissionRegistry>(limits, store));
  }
  MissionRegistry& a = *servers[0];
  MissionRegistry& b = *servers[1];
  MissionRegistry& c = *servers[2];
  // "b" and "c" stay alive for the whole test (however slow a sanitizer
  // makes it); "a" until it is made to fall silent below.
  const auto alive = [&](const std::string& holder, int ring_id, absl::Duration for_how_long) {
    ASSERT_TRUE(
        store->Heartbeat(holder, absl::ToUnixMicros(absl::Now() + for_how_long), ring_id).ok());
  };
  alive("a", 1, absl::Minutes(10));
  alive("b", 2, absl::Minutes(10));
  alive("c", 3, absl::Minutes(10));

  absl::StatusOr<api::MissionConfig> config = api::MissionSpecToConfig(testing::SmallSpec());
  ASSERT_TRUE(config.ok()) << config.status();
  std::vector<std::shared_ptr<Mission>> held;
  for (const std::string id : {"m-3", "m-10"}) {
    absl::StatusOr<std::shared_ptr<Mission>> created = a.Create(id, *config, "create-" + id);
    ASSERT_TRUE(created.ok()) << created.status();
    held.push_back(*created);
  }
  int measured = 0;
  const auto measure = [&](Mission& mission) {
    const int k = measured++;
    StoreMeasurement(*store, mission, k, -6.0 + k % 5);
  };
  for (int k = 0; k < 3; ++k) {
    measure(*held[0]);
    measure(*held[1]);
  }
  a.KeepStandbys();
  b.KeepStandbys();
  c.KeepStandbys();
  EXPECT_EQ(a.standbys(), 0);  // its own
  EXPECT_EQ(b.standbys(), 1);
  EXPECT_EQ(c.standbys(), 1);

  // "b" follows m-10 as "a" goes on; one more record comes after its last
  // look, and then "a" falls silent.
  measure(*held[1]);
  measure(*held[1]);
  b.KeepStandbys();
  measure(*held[1]);
  alive("a", 1, absl::Seconds(1));
  absl::SleepFor(absl::Seconds(1.1));
  absl::StatusOr<std::shared_ptr<Mission>> taken = b.Get("missions/m-10");
  ASSERT_TRUE(taken.ok()) << taken.status();
  EXPECT_EQ(b.takeovers(), 1);
  EXPECT_EQ(b.takeovers_from_standby(), 1);
  EXPECT_EQ(b.standbys(), 0);
  EXPECT_EQ((*taken)->Snapshot().measurements_fused, 6);
  EXPECT_EQ((*taken)->next_sequence(), held[1]->next_sequence());
  held[1]->ReadMap([&](const GpMap& want) {
    (*taken)->ReadMap([&](const GpMap& got) {
      EXPECT_EQ(got.Mean(), want.Mean());
      EXPECT_EQ(got.Covariance(), want.Covariance());
    });
  });

  // With "a" gone, "b" now holds m-10, and m-3 stays with "c"'s standby
  // until a call for it comes: "c" takes it from there.
  b.KeepStandbys();
  c.KeepStandbys();
  EXPECT_EQ(b.standbys(), 0);
  taken = c.Get("missions/m-3");
  ASSERT_TRUE(taken.ok()) << taken.status();
  EXPECT_EQ(c.takeovers_from_standby(), 1);
  EXPECT_EQ((*taken)->Snapshot().measurements_fused, 3);
}

// Standbys give way to missions: "b", with memory for two missions, stands
// by for one of "a"'s; when it creates two of its own, the standby goes
// (what it holds and stands by for would not fit), and "b" does not stand by
// again while they are there.
TEST(StandbyTest, StandbysGiveWayToTheMissionsAServerHolds) {
  FolderStore folder("oaipp-standby-memory");
  ASSERT_NE(folder.store, nullptr);
  MissionStore* const store = folder.store.get();
  absl::StatusOr<api::MissionConfig> config = api::MissionSpecToConfig(testing::SmallSpec());
  ASSERT_TRUE(config.ok()) << config.status();
  const std::int64_t mission_bytes = EstimateMissionBytes(*config).total();
  const auto limits = [&](const std::string& holder, int ring_id) {
    return RegistryLimits{.max_missions = 8,
                          .max_cells_per_mission = 1600,
                          .max_memory_bytes = 2 * mission_bytes + mission_bytes / 2,
                          .shared_store = true,
                          .holder = holder,
                          .ring_id = ring_id};
  };
  MissionRegistry a(limits("a", 1), store), b(limits("b", 2), store);
  for (const auto& [holder, ring_id] : {std::pair<std::string, int>{"a", 1}, {"b", 2}}) {
    ASSERT_TRUE(
        store->Heartbeat(holder, absl::ToUnixMicros(absl::Now() + absl::Minutes(10)), ring_id)
            .ok());
  }
  ASSERT_TRUE(a.Create("m-10", *config, "create-m-10").ok());
  b.KeepStandbys();
  EXPECT_EQ(b.standbys(), 1);  // with only "b" left, the ring sends everything to it
  ASSERT_TRUE(b.Create("b-1", *config, "create-b-1").ok());
  EXPECT_EQ(b.standbys(), 1);  // one held, one standing by: 2 of 2.5
  ASSERT_TRUE(b.Create("b-2", *config, "create-b-2").ok());
  EXPECT_EQ(b.standbys(), 0);
  b.KeepStandbys();
  EXPECT_EQ(b.standbys(), 0);
}

}  // namespace
}  // namespace oaipp::server
