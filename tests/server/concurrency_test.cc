// 8 client threads x 16 missions of interleaved measurements and plans: no
// measurement lost or fused twice (each mission's final Tr(P) equals a
// sequential replay of its log), no deadlock.
#include <atomic>
#include <random>
#include <thread>

#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"
#include "tests/server/service_fixture.h"

namespace oaipp::server {
namespace {

using testing::InProcessService;
using testing::LabelMeasurement;
using testing::SmallSpec;

TEST(ConcurrencyTest, InterleavedCallsLoseNothingAndReplayExactly) {
  constexpr int kMissions = 16;
  constexpr int kThreads = 8;
  constexpr int kCallsPerThread = 24;
  InProcessService s({.max_missions = 32, .max_cells_per_mission = 400}, /*planning_threads=*/2,
                     /*planning_queue=*/64);
  for (int m = 0; m < kMissions; ++m) {
    grpc::ClientContext context;
    v1::CreateMissionRequest request;
    request.set_mission_id(absl::StrCat("c", m));
    *request.mutable_spec() = SmallSpec();
    request.mutable_spec()->mutable_planner()->set_generations(1);
    v1::Mission out;
    ASSERT_TRUE(s.stub().CreateMission(&context, request, &out).ok());
  }
  std::atomic<int> measurements{0}, plans{0}, failures{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      std::mt19937 rng(100 + t);
      std::uniform_int_distribution<int> mission(0, kMissions - 1), kind(0, 3);
      std::uniform_real_distribution<double> xy(-6.5, 6.5), z(3, 20), label(0, 1);
      for (int i = 0; i < kCallsPerThread; ++i) {
        const std::string name = absl::StrCat("missions/c", mission(rng));
        grpc::ClientContext context;
        context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
        if (kind(rng) == 0) {
          v1::PlanPathRequest request;
          request.set_name(name);
          request.mutable_state()->mutable_position_m()->set_x(-4);
          request.mutable_state()->mutable_position_m()->set_y(4);
          request.mutable_state()->mutable_position_m()->set_z(8);
          v1::PlanPathResponse path;
          const grpc::Status st = s.stub().PlanPath(&context, request, &path);
          st.ok() ? ++plans : ++failures;
        } else {
          v1::AddMeasurementRequest request =
              LabelMeasurement(name, xy(rng), xy(rng), z(rng), i, label(rng) < 0.2 ? 1 : 0);
          request.set_request_id(absl::StrCat("t", t, "-", i));
          v1::AddMeasurementResponse r;
          const grpc::Status st = s.stub().AddMeasurement(&context, request, &r);
          st.ok() ? ++measurements : ++failures;
        }
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(failures.load(), 0);
  EXPECT_EQ(measurements + plans, kThreads * kCallsPerThread);

  std::int64_t fused = 0;
  for (int m = 0; m < kMissions; ++m) {
    auto mission = s.registry().Get(absl::StrCat("missions/c", m));
    ASSERT_TRUE(mission.ok());
    const MissionSnapshot snap = (*mission)->Snapshot();
    fused += snap.measurements_fused;
    auto replay = Mission::Replay("replay", snap.config, (*mission)->Log());
    ASSERT_TRUE(replay.ok()) << replay.status();
    EXPECT_NEAR((*replay)->Snapshot().trace, snap.trace, 1e-9 * snap.trace) << "mission " << m;
    EXPECT_EQ((*replay)->Snapshot().measurements_fused, snap.measurements_fused);
  }
  EXPECT_EQ(fused, measurements.load());
}

}  // namespace
}  // namespace oaipp::server
