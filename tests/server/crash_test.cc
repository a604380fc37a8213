// Durable missions against the real binary: eight clients drive eight
// missions (obstacle changes, measurements, plans) while the server is
// killed with SIGKILL at 20 seeded moments and stopped with SIGTERM at 3
// more, restarted each time on the same store: the SQLite file in a
// temporary folder, and a real PostgreSQL the test starts itself (initdb in a
// temporary folder, loopback only). Every call is retried
// with its request_id until it is acknowledged. At the end each mission's
// map equals an independent in-process replay of its acknowledged calls,
// nothing was lost and nothing was fused twice; the store read back after
// the last stop gives the same covariance.
#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <random>
#include <thread>
#include <variant>

#include "absl/strings/str_cat.h"
#include "api/geometry.h"
#include "api/measurement.h"
#include "api/spec.h"
#include "gtest/gtest.h"
#include "server/registry.h"
#include "server/store/postgres_store.h"
#include "server/store/sqlite_store.h"
#include "tests/server/postgres_instance.h"
#include "tests/server/server_process.h"
#include "tests/server/service_fixture.h"

namespace oaipp::server {
namespace {

constexpr int kMissions = 8;
constexpr int kStepsPerMission = 30;
constexpr int kSigkills = 20;
constexpr int kSigterms = 3;

// One mission's acknowledged changes, in the order they were acknowledged.
using Change = std::variant<v1::UpdateObstaclesRequest, v1::AddMeasurementRequest>;

v1::PlannerKind KindOf(int mission) {
  static constexpr v1::PlannerKind kKinds[] = {v1::PLANNER_KIND_OAIPP, v1::PLANNER_KIND_LAWNMOWER,
                                               v1::PLANNER_KIND_RANDOM};
  return kKinds[mission % 3];
}

// How long a restart may take to listen again. Recovery replays every
// mission first. Under the sanitizers, beside other tests' servers, a
// restart once missed the default 20 s without printing an error.
constexpr std::chrono::seconds kRestartWait{120};

// Retries `call` (a fresh context each time, waiting for the server) until
// it is acknowledged; fails the test on any answer but OK or a sign that the
// server was down. Gives up without retrying once `server_gone` is set (the
// server could not be restarted, a failure reported where that happened).
template <typename Call>
void UntilAcknowledged(const char* what, Call call,
                       const std::atomic<bool>* server_gone = nullptr) {
  for (int attempt = 0; attempt < 400; ++attempt) {
    if (server_gone != nullptr && *server_gone) return;
    grpc::ClientContext context;
    context.set_wait_for_ready(true);
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
    const grpc::Status status = call(context);
    if (status.ok()) return;
    const grpc::StatusCode code = status.error_code();
    if (code != grpc::StatusCode::UNAVAILABLE && code != grpc::StatusCode::DEADLINE_EXCEEDED &&
        code != grpc::StatusCode::CANCELLED && code != grpc::StatusCode::UNKNOWN) {
      ADD_FAILURE() << what << ": " << status.error_code() << " " << status.error_message();
      return;
    }
  }
  ADD_FAILURE() << what << ": never acknowledged";
}

// The parameter: the store's kind ("sqlite" or "postgresql").
class CrashTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           absl::StrCat("oaipp-crash-", GetParam(), "-", getpid());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    if (GetParam() == "postgresql") {
      if (!testing::PostgresInstance::Available()) {
        if (std::getenv("OAIPP_REQUIRE_POSTGRES") != nullptr) {
          FAIL() << "PostgreSQL 15 is not installed (deploy/install-deps.sh installs it)";
        }
        GTEST_SKIP() << "PostgreSQL 15 is not installed";
      }
      postgres_ = std::make_unique<testing::PostgresInstance>();
      ASSERT_TRUE(postgres_->Start());
    }
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string StoreFlag() const {
    return GetParam() == "sqlite" ? absl::StrCat("--data_dir=", dir_.string())
                                  : absl::StrCat("--store=", postgres_->uri());
  }
  absl::StatusOr<std::unique_ptr<MissionStore>> OpenDirectly() const {
    return GetParam() == "sqlite" ? OpenSqliteStore((dir_ / "missions.db").string())
                                  : OpenPostgresStore(postgres_->uri());
  }
  std::filesystem::path dir_;
  std::unique_ptr<testing::PostgresInstance> postgres_;
};

INSTANTIATE_TEST_SUITE_P(Stores, CrashTest, ::testing::Values("sqlite", "postgresql"),
                         [](const auto& param_info) { return param_info.param; });

TEST_P(CrashTest, KilledServerLosesNothingAcknowledgedAndAppliesNothingTwice) {
  std::mt19937 rng(20261123);
  const int port = testing::FreePort();
  // Snapshots every 4 measurements, so that kills also land while one is
  // written and recovery starts from them.
  // On Eigen, as the in-process twin below: the maps are compared to 1e-12
  // relative, closer than OpenBLAS's kernels agree with Eigen's on the
  // near-certain cells under buildings (variances ~1e-6).
  testing::ServerProcess server(
      port, {StoreFlag(), "--shutdown_grace_s=2", "--snapshot_every=4", "--dense_backend=eigen"});
  ASSERT_TRUE(server.Start()) << "oaipp-server did not start on " << server.address();
  auto channel = testing::QuickReconnectChannel(server.address());
  auto stub = v1::MissionService::NewStub(channel);

  // Kill points: after these many acknowledged calls in all (seeded).
  const int total_calls = kMissions * (kStepsPerMission + 1);
  std::vector<int> kill_after;
  std::uniform_int_distribution<int> when(1, total_calls - 1);
  for (int i = 0; i < kSigkills + kSigterms; ++i) kill_after.push_back(when(rng));
  std::sort(kill_after.begin(), kill_after.end());

  std::atomic<int> acknowledged{0};
  std::vector<std::vector<Change>> changes(kMissions);
  std::vector<int> measurements(kMissions, 0);
  // Set when a restart fails: the drivers stop instead of waiting for it.
  std::atomic<bool> server_gone{false};
  const auto ack = [&](const char* what, auto call) {
    UntilAcknowledged(what, call, &server_gone);
  };
  auto drive = [&](int m) {
    const std::string id = absl::StrCat("crash-", m);
    const std::string name = "missions/" + id;
    ack("CreateMission", [&](grpc::ClientContext& c) {
      v1::CreateMissionRequest r;
      r.set_mission_id(id);
      r.set_request_id(absl::StrCat("create-", m));
      *r.mutable_spec() = testing::SmallSpec();
      r.mutable_spec()->mutable_planner()->set_kind(KindOf(m));
      r.mutable_spec()->mutable_planner()->set_seed(static_cast<std::uint32_t>(m + 1));
      r.mutable_spec()->set_budget_s(1000);
      v1::Mission out;
      return stub->CreateMission(&c, r, &out);
    });
    ++acknowledged;
    for (int k = 0; k < kStepsPerMission && !server_gone; ++k) {
      const std::string request_id = absl::StrCat(m, "-", k);
      if (k % 10 == 3 || k % 10 == 8) {
        // A post on the field, added at k = 3 and removed at k = 8 of each ten.
        v1::UpdateObstaclesRequest r;
        r.set_name(name);
        r.set_request_id(request_id);
        const std::string post = absl::StrCat("post-", k / 10);
        if (k % 10 == 3) {
          v1::Obstacle* o = r.add_add();
          o->set_id(post);
          o->mutable_cylinder()->mutable_centre_m()->set_x(3.0 + k / 10);
          o->mutable_cylinder()->mutable_centre_m()->set_y(4.0);
          o->mutable_cylinder()->mutable_centre_m()->set_z(5.0);
          o->mutable_cylinder()->set_radius_m(0.8);
          o->mutable_cylinder()->set_height_m(10.0);
        } else {
          r.add_remove(post);
        }
        ack("UpdateObstacles", [&](grpc::ClientContext& c) {
          v1::UpdateObstaclesResponse out;
          return stub->UpdateObstacles(&c, r, &out);
        });
        changes[m].push_back(r);
      } else if (k % 5 == 1) {
        ack("PlanPath", [&](grpc::ClientContext& c) {
          v1::PlanPathRequest r;
          r.set_name(name);
          r.set_request_id(request_id);
          *r.mutable_state() = testing::SmallSpec().start();
          r.mutable_state()->set_mission_time_s(2.0 * k);
          v1::PlanPathResponse out;
          return stub->PlanPath(&c, r, &out);
        });
      } else {
        v1::AddMeasurementRequest r = testing::LabelMeasurement(
            name, -6.0 + 0.41 * k, 6.0 - 0.37 * k, 6.0 + (k % 4), 2.0 * k, (k + m) % 3 == 0);
        r.set_request_id(request_id);
        ack("AddMeasurement", [&](grpc::ClientContext& c) {
          v1::AddMeasurementResponse out;
          return stub->AddMeasurement(&c, r, &out);
        });
        changes[m].push_back(r);
        ++measurements[m];
      }
      ++acknowledged;
    }
  };

  std::atomic<bool> driving{true};
  int sigkills = 0, sigterms = 0;
  std::thread killer([&] {
    std::uniform_int_distribution<int> down_ms(0, 150);
    for (std::size_t i = 0; i < kill_after.size(); ++i) {
      while (driving && acknowledged < kill_after[i]) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
      if (!driving) return;
      const bool term = i >= static_cast<std::size_t>(kSigkills);
      server.Stop(term ? SIGTERM : SIGKILL);
      (term ? sigterms : sigkills)++;
      std::this_thread::sleep_for(std::chrono::milliseconds(down_ms(rng)));
      const auto restart = std::chrono::steady_clock::now();
      if (!server.Start(kRestartWait)) {
        ADD_FAILURE()
            << "restart " << i << " failed: not listening after "
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - restart).count()
            << " s";
        server_gone = true;
        return;
      }
    }
  });
  std::vector<std::thread> drivers;
  for (int m = 0; m < kMissions; ++m) drivers.emplace_back(drive, m);
  for (std::thread& t : drivers) t.join();
  driving = false;
  killer.join();
  EXPECT_EQ(sigkills, kSigkills);
  EXPECT_EQ(sigterms, kSigterms);
  if (server_gone) return;  // reported by the restart that failed

  // The live server against an independent replay of the acknowledged calls.
  std::vector<Eigen::MatrixXd> replayed(kMissions);
  for (int m = 0; m < kMissions; ++m) {
    SCOPED_TRACE(absl::StrCat("mission ", m));
    const std::string name = absl::StrCat("missions/crash-", m);
    v1::MissionSpec spec = testing::SmallSpec();
    spec.mutable_planner()->set_kind(KindOf(m));
    spec.mutable_planner()->set_seed(static_cast<std::uint32_t>(m + 1));
    spec.set_budget_s(1000);
    absl::StatusOr<MissionConfig> config = api::MissionSpecToConfig(spec);
    ASSERT_TRUE(config.ok());
    absl::StatusOr<std::shared_ptr<Mission>> twin = Mission::Create("twin", *config);
    ASSERT_TRUE(twin.ok());
    for (const Change& change : changes[m]) {
      if (const auto* o = std::get_if<v1::UpdateObstaclesRequest>(&change)) {
        ASSERT_TRUE((*twin)->UpdateObstacles(*api::ObstacleChangeFromProto(*o), "").ok());
      } else {
        const auto& a = std::get<v1::AddMeasurementRequest>(change);
        ASSERT_TRUE((*twin)->AddMeasurement(*api::MeasurementFromProto(a), "").ok());
      }
    }
    v1::GetMapResponse map;
    v1::Mission mission;
    UntilAcknowledged("GetMap", [&](grpc::ClientContext& c) {
      v1::GetMapRequest r;
      r.set_name(name);
      r.set_include_cells(true);
      return stub->GetMap(&c, r, &map);
    });
    UntilAcknowledged("GetMission", [&](grpc::ClientContext& c) {
      v1::GetMissionRequest r;
      r.set_name(name);
      return stub->GetMission(&c, r, &mission);
    });
    EXPECT_EQ(mission.measurements_fused(), measurements[m]);
    (*twin)->ReadMap([&](const GpMap& twin_map) {
      EXPECT_NEAR(map.trace(), twin_map.Trace(), 1e-12 * twin_map.Trace());
      ASSERT_EQ(map.mean_size(), twin_map.num_cells());
      for (int i = 0; i < twin_map.num_cells(); ++i) {
        ASSERT_NEAR(map.mean(i), twin_map.Mean()[i], 1e-12 * (1 + std::abs(twin_map.Mean()[i])));
        ASSERT_NEAR(map.variance(i), twin_map.Variance(i), 1e-12 * twin_map.Variance(i));
      }
      replayed[m] = twin_map.Covariance();
    });
    EXPECT_EQ(mission.obstacles_size(), static_cast<int>((*twin)->Snapshot().obstacles.size()));
  }
  stub.reset();
  channel.reset();
  server.Stop(SIGTERM);

  // The store itself, read back in-process: the same covariances.
  absl::StatusOr<std::unique_ptr<MissionStore>> store = OpenDirectly();
  ASSERT_TRUE(store.ok()) << store.status();
  // Recovery started from snapshots, not only from whole logs.
  absl::StatusOr<std::vector<StoredMission>> stored = (*store)->LoadAll();
  ASSERT_TRUE(stored.ok()) << stored.status();
  EXPECT_EQ(std::count_if(stored->begin(), stored->end(),
                          [](const StoredMission& m) { return m.snapshot.has_value(); }),
            kMissions);
  MissionRegistry registry({.max_missions = 64, .max_cells_per_mission = 1600}, store->get());
  absl::StatusOr<int> recovered = registry.Recover();
  ASSERT_TRUE(recovered.ok()) << recovered.status();
  EXPECT_EQ(*recovered, kMissions);
  for (int m = 0; m < kMissions; ++m) {
    absl::StatusOr<std::shared_ptr<Mission>> mission =
        registry.Get(absl::StrCat("missions/crash-", m));
    ASSERT_TRUE(mission.ok());
    (*mission)->ReadMap([&](const GpMap& map) {
      const double scale = replayed[m].cwiseAbs().maxCoeff();
      EXPECT_LE((map.Covariance() - replayed[m]).cwiseAbs().maxCoeff(), 1e-12 * scale)
          << "mission " << m;
    });
  }
}

}  // namespace
}  // namespace oaipp::server
