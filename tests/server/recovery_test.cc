// Durable missions in-process: a service on a real SQLite file, restarted
// (a new registry over the same file): every mission comes back with the
// same obstacles, map (mean and covariance bit for bit: the replay applies
// the same calls through the same code), counters, planner state and
// request_id answers; a store that fails leaves the mission untouched.
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "google/protobuf/util/message_differencer.h"
#include "gtest/gtest.h"
#include "server/store/sqlite_store.h"
#include "tests/server/service_fixture.h"

namespace oaipp::server {
namespace {

using testing::Eventually;
using testing::InProcessService;
using testing::LabelMeasurement;
using testing::SmallSpec;

class RecoveryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           (std::string("oaipp-recovery-") +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::unique_ptr<MissionStore> Open(const std::string& file = "missions.db") {
    absl::StatusOr<std::unique_ptr<MissionStore>> store = OpenSqliteStore((dir_ / file).string());
    EXPECT_TRUE(store.ok()) << store.status();
    return *std::move(store);
  }
  // The snapshot round trip of two missions driven through the service
  // (SnapshotsBoundTheTailAndRestoreTheMissionExactly).
  void CheckSnapshotsRestoreExactly(const RegistryLimits& limits);
  std::filesystem::path dir_;
};

grpc::Status Create(v1::MissionService::Stub& stub, const std::string& id, v1::PlannerKind kind,
                    v1::Mission* out) {
  grpc::ClientContext c;
  v1::CreateMissionRequest r;
  r.set_mission_id(id);
  r.set_request_id("create-" + id);
  *r.mutable_spec() = SmallSpec();
  r.mutable_spec()->mutable_planner()->set_kind(kind);
  return stub.CreateMission(&c, r, out);
}

grpc::Status Measure(v1::MissionService::Stub& stub, const std::string& name, int i,
                     v1::AddMeasurementResponse* out) {
  grpc::ClientContext c;
  v1::AddMeasurementRequest r =
      LabelMeasurement(name, -5.0 + 1.3 * i, 5.0 - 1.1 * i, 8.0, 2.0 * i, i % 3 == 0 ? 1.0 : 0.0);
  r.set_request_id(absl::StrCat("m", i));
  return stub.AddMeasurement(&c, r, out);
}

grpc::Status Plan(v1::MissionService::Stub& stub, const std::string& name, double time_s,
                  const std::string& request_id, v1::PlanPathResponse* out) {
  grpc::ClientContext c;
  v1::PlanPathRequest r;
  r.set_name(name);
  r.set_request_id(request_id);
  *r.mutable_state() = SmallSpec().start();
  r.mutable_state()->set_mission_time_s(time_s);
  return stub.PlanPath(&c, r, out);
}

v1::GetMapResponse Map(v1::MissionService::Stub& stub, const std::string& name) {
  grpc::ClientContext c;
  v1::GetMapRequest r;
  r.set_name(name);
  r.set_include_cells(true);
  v1::GetMapResponse out;
  EXPECT_TRUE(stub.GetMap(&c, r, &out).ok());
  return out;
}

Eigen::MatrixXd Covariance(MissionRegistry& registry, const std::string& name) {
  Eigen::MatrixXd p;
  absl::StatusOr<std::shared_ptr<Mission>> m = registry.Get(name);
  EXPECT_TRUE(m.ok());
  (*m)->ReadMap([&](const GpMap& map) { p = map.Covariance(); });
  return p;
}

// Drives two missions (OA-IPP and the lawnmower, whose place in its pattern
// is planner state) through obstacles, measurements and plans.
void Drive(v1::MissionService::Stub& stub) {
  for (const auto& [id, kind] :
       {std::pair{"a", v1::PLANNER_KIND_OAIPP}, std::pair{"l", v1::PLANNER_KIND_LAWNMOWER}}) {
    v1::Mission created;
    ASSERT_TRUE(Create(stub, id, kind, &created).ok());
    const std::string name = created.name();
    grpc::ClientContext c;
    v1::UpdateObstaclesRequest change;
    change.set_name(name);
    change.set_request_id("o1");
    v1::Obstacle* o = change.add_add();
    o->set_id("tower");
    o->mutable_cylinder()->mutable_centre_m()->set_x(4);
    o->mutable_cylinder()->mutable_centre_m()->set_y(4);
    o->mutable_cylinder()->mutable_centre_m()->set_z(6);
    o->mutable_cylinder()->set_radius_m(1);
    o->mutable_cylinder()->set_height_m(12);
    v1::UpdateObstaclesResponse changed;
    ASSERT_TRUE(stub.UpdateObstacles(&c, change, &changed).ok());
    for (int i = 0; i < 6; ++i) {
      v1::AddMeasurementResponse fused;
      ASSERT_TRUE(Measure(stub, name, i, &fused).ok());
    }
    v1::PlanPathResponse plan;
    ASSERT_TRUE(Plan(stub, name, 12.0, "p1", &plan).ok());
    ASSERT_TRUE(Plan(stub, name, 20.0, "p2", &plan).ok());
  }
}

TEST_F(RecoveryTest, EveryMissionComesBackAsItWas) {
  std::unique_ptr<MissionStore> store = Open();
  auto before = std::make_unique<InProcessService>(
      RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600}, 2, 64, store.get());
  Drive(before->stub());
  std::map<std::string, v1::GetMapResponse> maps;
  std::map<std::string, Eigen::MatrixXd> covariances;
  std::map<std::string, v1::Mission> missions;
  for (const std::string name : {"missions/a", "missions/l"}) {
    maps[name] = Map(before->stub(), name);
    covariances[name] = Covariance(before->registry(), name);
    grpc::ClientContext c;
    v1::GetMissionRequest r;
    r.set_name(name);
    ASSERT_TRUE(before->stub().GetMission(&c, r, &missions[name]).ok());
  }
  before.reset();
  store.reset();

  store = Open();
  InProcessService after(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600}, 2, 64,
                         store.get());
  absl::StatusOr<int> recovered = after.recovered();
  ASSERT_TRUE(recovered.ok()) << recovered.status();
  EXPECT_EQ(*recovered, 2);
  for (const std::string name : {"missions/a", "missions/l"}) {
    SCOPED_TRACE(name);
    const v1::GetMapResponse map = Map(after.stub(), name);
    ASSERT_EQ(map.mean_size(), maps[name].mean_size());
    EXPECT_EQ(map.trace(), maps[name].trace());
    for (int i = 0; i < map.mean_size(); ++i) {
      ASSERT_EQ(map.mean(i), maps[name].mean(i)) << i;
      ASSERT_EQ(map.variance(i), maps[name].variance(i)) << i;
    }
    EXPECT_TRUE(Covariance(after.registry(), name) == covariances[name]);
    grpc::ClientContext c;
    v1::GetMissionRequest r;
    r.set_name(name);
    v1::Mission mission;
    ASSERT_TRUE(after.stub().GetMission(&c, r, &mission).ok());
    EXPECT_EQ(mission.measurements_fused(), missions[name].measurements_fused());
    EXPECT_EQ(mission.paths_planned(), missions[name].paths_planned());
    EXPECT_EQ(mission.obstacles_size(), 2);
    EXPECT_TRUE(
        google::protobuf::util::MessageDifferencer::Equals(mission.spec(), missions[name].spec()));
  }
}

TEST_F(RecoveryTest, RetriesAfterARestartAreAnsweredOnceWithTheFirstResult) {
  std::unique_ptr<MissionStore> store = Open();
  v1::AddMeasurementResponse first_fused;
  v1::PlanPathResponse first_plan;
  {
    InProcessService before(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600}, 2, 64,
                            store.get());
    Drive(before.stub());
    ASSERT_TRUE(Measure(before.stub(), "missions/a", 3, &first_fused).ok());  // a retry already
    ASSERT_TRUE(Plan(before.stub(), "missions/l", 20.0, "p2", &first_plan).ok());
  }
  store = Open();
  InProcessService after(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600}, 2, 64,
                         store.get());
  ASSERT_TRUE(after.recovered().ok());
  v1::AddMeasurementResponse fused;
  ASSERT_TRUE(Measure(after.stub(), "missions/a", 3, &fused).ok());
  EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(fused, first_fused));
  EXPECT_EQ(fused.measurements_fused(), 4);  // the answer when it was first fused
  v1::PlanPathResponse plan;
  ASSERT_TRUE(Plan(after.stub(), "missions/l", 20.0, "p2", &plan).ok());
  EXPECT_EQ(plan.SerializeAsString(), first_plan.SerializeAsString());
  // The same request_id for another measurement is refused after the
  // restart too.
  {
    grpc::ClientContext c;
    v1::AddMeasurementRequest other = LabelMeasurement("missions/a", 1, 1, 8, 30, 1);
    other.set_request_id("m3");
    v1::AddMeasurementResponse out;
    EXPECT_EQ(after.stub().AddMeasurement(&c, other, &out).error_code(),
              grpc::StatusCode::INVALID_ARGUMENT);
  }
  // A retried create returns the mission, not a new one; nothing was fused
  // twice.
  v1::Mission again;
  ASSERT_TRUE(Create(after.stub(), "a", v1::PLANNER_KIND_OAIPP, &again).ok());
  EXPECT_EQ(again.measurements_fused(), 6);
}

TEST_F(RecoveryTest, TheLawnmowerGoesOnFromItsPlaceInThePattern) {
  std::unique_ptr<MissionStore> store = Open();
  InProcessService running(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600}, 2, 64,
                           store.get());
  Drive(running.stub());
  // A copy of the file as it is now (no write in flight): a restarted twin.
  std::filesystem::copy_file(dir_ / "missions.db", dir_ / "twin.db");
  if (std::filesystem::exists(dir_ / "missions.db-wal")) {
    std::filesystem::copy_file(dir_ / "missions.db-wal", dir_ / "twin.db-wal");
  }
  std::unique_ptr<MissionStore> twin_store = Open("twin.db");
  InProcessService twin(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600}, 2, 64,
                        twin_store.get());
  ASSERT_TRUE(twin.recovered().ok());
  v1::PlanPathResponse expected, got;
  ASSERT_TRUE(Plan(running.stub(), "missions/l", 30.0, "p3", &expected).ok());
  ASSERT_TRUE(Plan(twin.stub(), "missions/l", 30.0, "p3", &got).ok());
  EXPECT_EQ(got.trajectory().SerializeAsString(), expected.trajectory().SerializeAsString());
  ASSERT_EQ(got.control_waypoints_m_size(), expected.control_waypoints_m_size());
  for (int i = 0; i < got.control_waypoints_m_size(); ++i) {
    EXPECT_EQ(got.control_waypoints_m(i).x(), expected.control_waypoints_m(i).x());
    EXPECT_EQ(got.control_waypoints_m(i).y(), expected.control_waypoints_m(i).y());
  }
}

TEST_F(RecoveryTest, ServerAssignedIdsNeverRepeatAcrossRestarts) {
  std::string first;
  {
    std::unique_ptr<MissionStore> store = Open();
    InProcessService before({}, 2, 64, store.get());
    grpc::ClientContext c;
    v1::CreateMissionRequest r;
    *r.mutable_spec() = SmallSpec();
    v1::Mission m;
    ASSERT_TRUE(before.stub().CreateMission(&c, r, &m).ok());
    first = m.name();
    grpc::ClientContext d;
    v1::DeleteMissionRequest del;
    del.set_name(first);
    v1::DeleteMissionResponse deleted;
    ASSERT_TRUE(before.stub().DeleteMission(&d, del, &deleted).ok());
  }
  std::unique_ptr<MissionStore> store = Open();
  InProcessService after({}, 2, 64, store.get());
  ASSERT_TRUE(after.recovered().ok());
  EXPECT_EQ(after.registry().size(), 0u);  // the deleted mission stays deleted
  grpc::ClientContext c;
  v1::CreateMissionRequest r;
  *r.mutable_spec() = SmallSpec();
  v1::Mission m;
  ASSERT_TRUE(after.stub().CreateMission(&c, r, &m).ok());
  EXPECT_EQ(first, "missions/m-000001");
  EXPECT_EQ(m.name(), "missions/m-000002");
}

// The real store, with writes that can be made to fail (the disk gone, the
// database down): the fault is injected, the storage is real.
class FailingStore final : public MissionStore {
 public:
  explicit FailingStore(MissionStore* store) : store_(store) {}
  // Read by the server's threads (its health probe among them) while the
  // test flips it.
  std::atomic<bool> fail = false;
  absl::StatusOr<std::int64_t> NextMissionNumber() override { return store_->NextMissionNumber(); }
  absl::Status CreateMission(const StoredMission& m) override {
    return fail ? Down() : store_->CreateMission(m);
  }
  absl::Status Append(const std::string& id, const LogRecord& r) override {
    if (in_doubt) {
      // Written, but the answer lost on the way (a connection cut while
      // committing).
      (void)store_->Append(id, r);
      absl::Status lost = absl::UnavailableError("store: injected loss of the commit's answer");
      lost.SetPayload(kInDoubt, absl::Cord("1"));
      return lost;
    }
    return fail ? Down() : store_->Append(id, r);
  }
  std::atomic<bool> in_doubt = false;
  absl::Status PutSnapshot(const std::string& id, const StoredSnapshot& s) override {
    return fail ? Down() : store_->PutSnapshot(id, s);
  }
  absl::StatusOr<StoredMission> Load(const std::string& id) override { return store_->Load(id); }
  absl::Status ForgetDeletionsBefore(std::int64_t unix_us) override {
    return fail ? Down() : store_->ForgetDeletionsBefore(unix_us);
  }
  absl::Status DeleteMission(const std::string& id, const std::string& request_id,
                             std::int64_t epoch) override {
    return fail ? Down() : store_->DeleteMission(id, request_id, epoch);
  }
  absl::StatusOr<StoredMission> Claim(const std::string& id, std::int64_t have_through) override {
    if (fail) return Down();
    return store_->Claim(id, have_through);
  }
  absl::StatusOr<std::int64_t> LeaseHolderAliveUntil(const std::string& name) override {
    return store_->LeaseHolderAliveUntil(name);
  }
  absl::StatusOr<std::int64_t> Epoch(const std::string& id) override { return store_->Epoch(id); }
  absl::StatusOr<StoredMission> CreatedBy(const std::string& r) override {
    return store_->CreatedBy(r);
  }
  absl::StatusOr<std::vector<StoredMission>> LoadAll() override { return store_->LoadAll(); }
  absl::StatusOr<std::string> DeletedBy(const std::string& r) override {
    return store_->DeletedBy(r);
  }
  absl::Status Health() override { return fail ? Down() : store_->Health(); }
  absl::StatusOr<std::vector<MissionListing>> List(const std::string& prefix, std::int64_t t,
                                                   const std::string& id, int limit) override {
    return store_->List(prefix, t, id, limit);
  }
  absl::StatusOr<std::string> SigningKey() override { return store_->SigningKey(); }
  absl::StatusOr<bool> TryLease(const std::string& name, const std::string& holder,
                                std::int64_t now_us, std::int64_t until_us, bool silent) override {
    return store_->TryLease(name, holder, now_us, until_us, silent);
  }
  absl::Status Heartbeat(const std::string& holder, std::int64_t until_us, int ring_id) override {
    return store_->Heartbeat(holder, until_us, ring_id);
  }
  absl::Status Retire(const std::string& holder) override { return store_->Retire(holder); }
  absl::StatusOr<std::vector<std::pair<std::string, std::int64_t>>> IdleSince(
      std::int64_t before_us, int limit) override {
    return store_->IdleSince(before_us, limit);
  }

 private:
  static absl::Status Down() { return absl::UnavailableError("store: injected failure"); }
  MissionStore* store_;
};

TEST_F(RecoveryTest, AFailedWriteAppliesNothing) {
  std::unique_ptr<MissionStore> real = Open();
  FailingStore store(real.get());
  InProcessService service(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600}, 2, 64,
                           &store);
  v1::Mission created;
  ASSERT_TRUE(Create(service.stub(), "a", v1::PLANNER_KIND_LAWNMOWER, &created).ok());
  v1::AddMeasurementResponse fused;
  ASSERT_TRUE(Measure(service.stub(), "missions/a", 0, &fused).ok());
  v1::PlanPathResponse plan;
  ASSERT_TRUE(Plan(service.stub(), "missions/a", 2.0, "p1", &plan).ok());
  const v1::GetMapResponse map = Map(service.stub(), "missions/a");

  store.fail = true;
  EXPECT_EQ(Measure(service.stub(), "missions/a", 1, &fused).error_code(),
            grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(Plan(service.stub(), "missions/a", 4.0, "p2", &plan).error_code(),
            grpc::StatusCode::UNAVAILABLE);
  v1::Mission other;
  EXPECT_EQ(Create(service.stub(), "b", v1::PLANNER_KIND_OAIPP, &other).error_code(),
            grpc::StatusCode::UNAVAILABLE);
  // Nothing changed, and the refused id is free.
  const v1::GetMapResponse unchanged = Map(service.stub(), "missions/a");
  EXPECT_EQ(unchanged.SerializeAsString(), map.SerializeAsString());
  EXPECT_EQ(service.registry().size(), 1u);

  store.fail = false;
  ASSERT_TRUE(Measure(service.stub(), "missions/a", 1, &fused).ok());
  EXPECT_EQ(fused.measurements_fused(), 2);
  v1::PlanPathResponse retried;
  ASSERT_TRUE(Plan(service.stub(), "missions/a", 4.0, "p2", &retried).ok());
  ASSERT_TRUE(Create(service.stub(), "b", v1::PLANNER_KIND_OAIPP, &other).ok());
  // The log has no gap: a restart replays it.
  std::unique_ptr<MissionStore> reopened = Open();
  InProcessService after(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600}, 2, 64,
                         reopened.get());
  absl::StatusOr<int> recovered = after.recovered();
  ASSERT_TRUE(recovered.ok()) << recovered.status();
  EXPECT_EQ(*recovered, 2);
  EXPECT_EQ(Map(after.stub(), "missions/a").SerializeAsString(),
            Map(service.stub(), "missions/a").SerializeAsString());
  // The failed plan left the lawnmower where it was: the retried p2 is the
  // one a mission that never saw the failure flies.
  v1::Mission twin;
  ASSERT_TRUE(Create(service.stub(), "c", v1::PLANNER_KIND_LAWNMOWER, &twin).ok());
  ASSERT_TRUE(Plan(service.stub(), "missions/c", 2.0, "p1", &plan).ok());
  v1::PlanPathResponse twin_p2;
  ASSERT_TRUE(Plan(service.stub(), "missions/c", 4.0, "p2", &twin_p2).ok());
  EXPECT_EQ(retried.trajectory().SerializeAsString(), twin_p2.trajectory().SerializeAsString());
}

TEST_F(RecoveryTest, AWriteInDoubtIsReadBackAndAppliedOnce) {
  std::unique_ptr<MissionStore> real = Open();
  FailingStore store(real.get());
  InProcessService service(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600}, 2, 64,
                           &store);
  v1::Mission created;
  ASSERT_TRUE(Create(service.stub(), "a", v1::PLANNER_KIND_OAIPP, &created).ok());
  v1::AddMeasurementResponse fused;
  ASSERT_TRUE(Measure(service.stub(), "missions/a", 0, &fused).ok());
  store.in_doubt = true;
  EXPECT_EQ(Measure(service.stub(), "missions/a", 1, &fused).error_code(),
            grpc::StatusCode::UNAVAILABLE);
  store.in_doubt = false;
  // The record reached the store: the mission was read back with it, and
  // the retry is answered, not fused again.
  ASSERT_TRUE(Measure(service.stub(), "missions/a", 1, &fused).ok());
  EXPECT_EQ(fused.measurements_fused(), 2);
  ASSERT_TRUE(Measure(service.stub(), "missions/a", 2, &fused).ok());
  EXPECT_EQ(fused.measurements_fused(), 3);
  // Equal to a mission that never saw the doubt.
  v1::Mission twin;
  ASSERT_TRUE(Create(service.stub(), "b", v1::PLANNER_KIND_OAIPP, &twin).ok());
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(Measure(service.stub(), "missions/b", i, &fused).ok());
  EXPECT_TRUE(Covariance(service.registry(), "missions/a") ==
              Covariance(service.registry(), "missions/b"));
}

void RecoveryTest::CheckSnapshotsRestoreExactly(const RegistryLimits& limits) {
  std::unique_ptr<MissionStore> store = Open();
  InProcessService running(limits, 2, 64, store.get());
  Drive(running.stub());
  running.registry().FlushSnapshots();
  EXPECT_GE(running.registry().snapshots_written(), 2);
  for (const std::string id : {"a", "l"}) {
    absl::StatusOr<StoredMission> stored = store->Load(id);
    ASSERT_TRUE(stored.ok()) << stored.status();
    ASSERT_TRUE(stored->snapshot.has_value());
    // 9 records: an obstacle change, 6 measurements, 2 plans. Whenever the
    // background writer got to them, the snapshots leave fewer than 2
    // measurements after the last one (so it covers record 6 or later), and
    // the store keeps only the records that follow it.
    EXPECT_GE(stored->snapshot->sequence, 6);
    EXPECT_EQ(stored->snapshot->sequence + static_cast<std::int64_t>(stored->log.size()), 9);
  }
  std::filesystem::copy_file(dir_ / "missions.db", dir_ / "twin.db");
  if (std::filesystem::exists(dir_ / "missions.db-wal")) {
    std::filesystem::copy_file(dir_ / "missions.db-wal", dir_ / "twin.db-wal");
  }
  std::unique_ptr<MissionStore> twin_store = Open("twin.db");
  InProcessService twin(limits, 2, 64, twin_store.get());
  absl::StatusOr<int> recovered = twin.recovered();
  ASSERT_TRUE(recovered.ok()) << recovered.status();
  ASSERT_EQ(*recovered, 2);
  for (const std::string name : {"missions/a", "missions/l"}) {
    SCOPED_TRACE(name);
    EXPECT_TRUE(Covariance(twin.registry(), name) == Covariance(running.registry(), name));
    EXPECT_EQ(Map(twin.stub(), name).SerializeAsString(),
              Map(running.stub(), name).SerializeAsString());
    // Answers from the snapshot (m3, before it) and the tail (p2, after it).
    v1::AddMeasurementResponse first, again;
    ASSERT_TRUE(Measure(running.stub(), name, 3, &first).ok());
    ASSERT_TRUE(Measure(twin.stub(), name, 3, &again).ok());
    EXPECT_EQ(again.SerializeAsString(), first.SerializeAsString());
    EXPECT_EQ(again.measurements_fused(), 4);
    v1::PlanPathResponse p2, p2_again;
    ASSERT_TRUE(Plan(running.stub(), name, 20.0, "p2", &p2).ok());
    ASSERT_TRUE(Plan(twin.stub(), name, 20.0, "p2", &p2_again).ok());
    EXPECT_EQ(p2_again.SerializeAsString(), p2.SerializeAsString());
    // The next plan: the same world, map and planner state give the same
    // trajectory.
    v1::PlanPathResponse next, next_twin;
    ASSERT_TRUE(Plan(running.stub(), name, 30.0, "p3", &next).ok());
    ASSERT_TRUE(Plan(twin.stub(), name, 30.0, "p3", &next_twin).ok());
    EXPECT_EQ(next_twin.trajectory().SerializeAsString(), next.trajectory().SerializeAsString());
    v1::GetMissionRequest r;
    r.set_name(name);
    v1::Mission m1, m2;
    // A sparse map's trace is computed after the measurement, in the
    // background: compared once both are current.
    ASSERT_TRUE(Eventually([&] {
      grpc::ClientContext c1, c2;
      return running.stub().GetMission(&c1, r, &m1).ok() &&
             twin.stub().GetMission(&c2, r, &m2).ok() &&
             m1.trace_measurements_fused() == m1.measurements_fused() &&
             m2.trace_measurements_fused() == m2.measurements_fused();
    }));
    EXPECT_EQ(m2.SerializeAsString(), m1.SerializeAsString());  // counters, obstacles, times
  }
}

// With a snapshot every 2 measurements: the store keeps a snapshot and a
// short tail, and the mission read back from them is the one that wrote
// them (map bit for bit, counters, answers, the next plans).
TEST_F(RecoveryTest, SnapshotsBoundTheTailAndRestoreTheMissionExactly) {
  CheckSnapshotsRestoreExactly(
      {.max_missions = 8, .max_cells_per_mission = 1600, .snapshot_every = 2});
}

// The same for missions on the sparse map (docs/method.md §3.11): their
// snapshots hold what was fused, and the map read back agrees bit for bit.
TEST_F(RecoveryTest, SparseMissionsComeBackFromSnapshotsExactly) {
  CheckSnapshotsRestoreExactly({.max_missions = 8,
                                .max_cells_per_mission = 1600,
                                .max_dense_cells = 1,
                                .snapshot_every = 2});
}

// A sparse map's measurement is answered with the newest trace of a
// background refresh, which a replay cannot compute again: the answer is
// stored with the record, and a retry after a restart gets the first answer
// bit for bit, not the trace the replay happened to have.
TEST_F(RecoveryTest, ARetryAfterARestartGetsASparseMeasurementsFirstAnswer) {
  const RegistryLimits limits{
      .max_missions = 8, .max_cells_per_mission = 1600, .max_dense_cells = 1, .snapshot_every = 0};
  std::unique_ptr<MissionStore> store = Open();
  v1::AddMeasurementResponse first;
  {
    InProcessService before(limits, 2, 64, store.get());
    v1::Mission created;
    ASSERT_TRUE(Create(before.stub(), "s", v1::PLANNER_KIND_OAIPP, &created).ok());
    v1::AddMeasurementResponse fused;
    ASSERT_TRUE(Measure(before.stub(), "missions/s", 0, &fused).ok());
    // The refresh after the answer brings the trace up to the first
    // measurement (bounded wait: 60 s).
    v1::Mission now;
    for (int i = 0; i < 600 && now.trace_measurements_fused() < 1; ++i) {
      absl::SleepFor(absl::Milliseconds(100));
      grpc::ClientContext c;
      v1::GetMissionRequest r;
      r.set_name("missions/s");
      ASSERT_TRUE(before.stub().GetMission(&c, r, &now).ok());
    }
    ASSERT_EQ(now.trace_measurements_fused(), 1);
    ASSERT_TRUE(Measure(before.stub(), "missions/s", 1, &first).ok());
    // The second answer carries the refreshed trace; a replay of the log
    // alone would answer with the prior's.
    ASSERT_EQ(first.trace_measurements_fused(), 1);
  }
  InProcessService after(limits, 2, 64, store.get());
  ASSERT_TRUE(after.recovered().ok());
  v1::AddMeasurementResponse retried;
  ASSERT_TRUE(Measure(after.stub(), "missions/s", 1, &retried).ok());
  EXPECT_EQ(retried.SerializeAsString(), first.SerializeAsString())
      << "first: " << first.ShortDebugString() << "\nretry: " << retried.ShortDebugString();
  EXPECT_EQ(retried.measurements_fused(), 2);
}

// The objective's precision is the server's setting, not the spec's: a
// mission takes it from the registry that creates it and again from the one
// that recovers it.
TEST_F(RecoveryTest, TheObjectivePrecisionIsTheHoldingServersSetting) {
  auto single_precision = [](MissionRegistry& registry, const std::string& name) {
    absl::StatusOr<std::shared_ptr<Mission>> m = registry.Get(name);
    EXPECT_TRUE(m.ok()) << m.status();
    return m.ok() && (*m)->config().planner.common.information.single_precision;
  };
  std::unique_ptr<MissionStore> store = Open();
  {
    InProcessService single(
        RegistryLimits{.max_cells_per_mission = 1600, .single_precision_objective = true}, 2, 64,
        store.get());
    v1::Mission created;
    ASSERT_TRUE(Create(single.stub(), "a", v1::PLANNER_KIND_OAIPP, &created).ok());
    EXPECT_TRUE(single_precision(single.registry(), "missions/a"));
    v1::PlanPathResponse plan;
    ASSERT_TRUE(Plan(single.stub(), "missions/a", 12.0, "p1", &plan).ok());
  }
  InProcessService twin(RegistryLimits{.max_cells_per_mission = 1600}, 2, 64, store.get());
  ASSERT_TRUE(twin.recovered().ok());
  EXPECT_FALSE(single_precision(twin.registry(), "missions/a"));
}

TEST_F(RecoveryTest, RetentionDeletesFinishedAndIdleMissionsWithTheirRecords) {
  std::unique_ptr<MissionStore> store = Open();
  InProcessService service(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600}, 2, 64,
                           store.get());
  v1::Mission created;
  ASSERT_TRUE(Create(service.stub(), "done", v1::PLANNER_KIND_OAIPP, &created).ok());
  ASSERT_TRUE(Create(service.stub(), "flying", v1::PLANNER_KIND_OAIPP, &created).ok());
  v1::AddMeasurementResponse fused;
  ASSERT_TRUE(Measure(service.stub(), "missions/flying", 1, &fused).ok());
  // A measurement at the end of the 60 s budget finishes "done".
  grpc::ClientContext c;
  v1::AddMeasurementRequest last = testing::LabelMeasurement("missions/done", 0, 0, 8, 60.0, 0);
  ASSERT_TRUE(service.stub().AddMeasurement(&c, last, &fused).ok());
  const absl::Time now = absl::Now();
  // Not yet: changed less than a minute ago.
  EXPECT_TRUE(service.registry().Sweep(now, absl::Minutes(1), absl::InfiniteDuration()).empty());
  EXPECT_EQ(
      service.registry().Sweep(now + absl::Minutes(2), absl::Minutes(1), absl::InfiniteDuration()),
      std::vector<std::string>{"done"});
  absl::StatusOr<std::vector<StoredMission>> left = store->LoadAll();
  ASSERT_TRUE(left.ok());
  ASSERT_EQ(left->size(), 1u);
  EXPECT_EQ(left->front().id, "flying");
  // Idle for longer than keep_idle: gone too, finished or not.
  EXPECT_EQ(service.registry().Sweep(now + absl::Hours(2), absl::Hours(24), absl::Hours(1)),
            std::vector<std::string>{"flying"});
  EXPECT_TRUE(store->LoadAll()->empty());
  EXPECT_EQ(service.registry().size(), 0u);
}

// A real full disk: the store on a 1 MB tmpfs, filled up. The measurement
// that no longer fits fails RESOURCE_EXHAUSTED and is not applied, health
// fails, and once there is room again the retry is applied once and the file
// recovers. Needs root to mount; skipped where mounting is not allowed.
class DiskFullTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / absl::StrCat("oaipp-full-", getpid());
    std::filesystem::create_directories(dir_);
    const std::string mount =
        absl::StrCat("mount -t tmpfs -o size=1m tmpfs ", dir_.string(), " 2>/dev/null");
    mounted_ = std::system(mount.c_str()) == 0;
    if (!mounted_) GTEST_SKIP() << "cannot mount a tmpfs here (needs root)";
  }
  void TearDown() override {
    if (mounted_) (void)std::system(absl::StrCat("umount ", dir_.string()).c_str());
    std::filesystem::remove_all(dir_);
  }
  std::filesystem::path dir_;
  bool mounted_ = false;
};

// A measurement labelling every cell of the 20 x 20 field (~4 kB).
v1::AddMeasurementRequest WholeFieldMeasurement(int i) {
  v1::AddMeasurementRequest r = LabelMeasurement("missions/a", 0.0, 0.0, 8.0, 0.5 * i, 0.0);
  r.mutable_labels()->Clear();
  for (int c = 0; c < 400; ++c) {
    r.mutable_labels()->add_cells(c);
    r.mutable_labels()->add_labels((c + i) % 7 == 0 ? 1.0 : 0.0);
  }
  r.set_request_id(absl::StrCat("w", i));
  return r;
}

TEST_F(DiskFullTest, AWriteThatDoesNotFitIsResourceExhaustedAndNotApplied) {
  absl::StatusOr<std::unique_ptr<MissionStore>> store =
      OpenSqliteStore((dir_ / "missions.db").string());
  ASSERT_TRUE(store.ok()) << store.status();
  InProcessService service(
      RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600, .snapshot_every = 0}, 2, 64,
      store->get());
  v1::Mission created;
  ASSERT_TRUE(Create(service.stub(), "a", v1::PLANNER_KIND_OAIPP, &created).ok());
  // Fill what is left of the disk.
  {
    std::FILE* filler = std::fopen((dir_ / "filler").c_str(), "wb");
    ASSERT_NE(filler, nullptr);
    const std::string block(4096, 'f');
    while (std::fwrite(block.data(), 1, block.size(), filler) == block.size() &&
           std::fflush(filler) == 0) {
    }
    std::fclose(filler);
  }
  // Space the journal already holds may take a few more records; then one
  // does not fit.
  int fused = 0;
  grpc::Status refused;
  for (int i = 0; i < 300 && refused.ok(); ++i) {
    grpc::ClientContext c;
    v1::AddMeasurementResponse out;
    refused = service.stub().AddMeasurement(&c, WholeFieldMeasurement(i), &out);
    if (refused.ok()) fused = static_cast<int>(out.measurements_fused());
  }
  ASSERT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  const v1::GetMapResponse map = Map(service.stub(), "missions/a");
  {
    grpc::ClientContext c;
    v1::GetMissionRequest r;
    r.set_name("missions/a");
    v1::Mission m;
    ASSERT_TRUE(service.stub().GetMission(&c, r, &m).ok());
    EXPECT_EQ(m.measurements_fused(), fused);  // the refused one is not in memory
  }
  EXPECT_FALSE((*store)->Health().ok());

  std::filesystem::remove(dir_ / "filler");
  EXPECT_TRUE((*store)->Health().ok());
  grpc::ClientContext c;
  v1::AddMeasurementResponse out;
  ASSERT_TRUE(service.stub().AddMeasurement(&c, WholeFieldMeasurement(fused), &out).ok());
  EXPECT_EQ(out.measurements_fused(), fused + 1);
  EXPECT_NE(Map(service.stub(), "missions/a").trace(), map.trace());
  // The file holds exactly what was acknowledged.
  std::unique_ptr<MissionStore> reopened = *OpenSqliteStore((dir_ / "missions.db").string());
  InProcessService after(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600}, 2, 64,
                         reopened.get());
  ASSERT_TRUE(after.recovered().ok());
  EXPECT_EQ(Map(after.stub(), "missions/a").SerializeAsString(),
            Map(service.stub(), "missions/a").SerializeAsString());
}

}  // namespace
}  // namespace oaipp::server
