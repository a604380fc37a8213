// What the team tests share (tests/server/team_test.cc,
// team_member_test.cc and team_removal_test.cc): a small team spec, its
// calls, this file's own evaluation of a returned path, independent of the
// server's code, and a fixture with a store of its own.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"
#include "server/store/sqlite_store.h"
#include "tests/server/service_fixture.h"

namespace oaipp::server::testing {

inline constexpr double kSeparation = 4.0;

struct Point {
  double x, y, z;
};

// A 30 x 30 m field at 1.5 m (400 cells; a plan costs a tenth of one at
// 0.75 m) with the prior's length scale of 0.75 m cells, 2.75 m, kept (the
// paper preset's is 3.67 cells whatever their size), one building (x in
// [-1, 1], y in [-4, 0]), a short CMA-ES, and a team at `starts` (ids a, b,
// c, ...). What these tests check does not depend on the cells' size.
inline v1::MissionSpec TeamSpec(const std::vector<Point>& starts) {
  v1::MissionSpec spec = SmallSpec();
  spec.mutable_field()->set_x_min_m(-15);
  spec.mutable_field()->set_y_min_m(-15);
  spec.mutable_field()->set_x_max_m(15);
  spec.mutable_field()->set_y_max_m(15);
  spec.mutable_field()->set_resolution_m(1.5);
  spec.mutable_gp()->set_length_scale_m(2.75);
  spec.set_min_separation_m(kSeparation);
  for (std::size_t i = 0; i < starts.size(); ++i) {
    v1::TeamMember* m = spec.add_team();
    m->set_uav_id(std::string(1, static_cast<char>('a' + i)));
    m->mutable_start()->mutable_position_m()->set_x(starts[i].x);
    m->mutable_start()->mutable_position_m()->set_y(starts[i].y);
    m->mutable_start()->mutable_position_m()->set_z(starts[i].z);
  }
  return spec;
}

inline grpc::Status CreateTeam(v1::MissionService::Stub& stub, const std::string& id,
                               const v1::MissionSpec& spec, v1::Mission* out) {
  grpc::ClientContext c;
  v1::CreateMissionRequest r;
  r.set_mission_id(id);
  r.set_request_id("create-" + id);
  *r.mutable_spec() = spec;
  return stub.CreateMission(&c, r, out);
}

inline grpc::Status PlanFor(v1::MissionService::Stub& stub, const std::string& mission,
                            const std::string& uav_id, const v1::UavState& state,
                            const std::string& request_id, v1::PlanPathResponse* out) {
  grpc::ClientContext c;
  v1::PlanPathRequest r;
  r.set_name("missions/" + mission);
  r.set_uav_id(uav_id);
  r.set_request_id(request_id);
  *r.mutable_state() = state;
  return stub.PlanPath(&c, r, out);
}

inline v1::UavState At(const Point& p, double mission_time_s) {
  v1::UavState s;
  s.mutable_position_m()->set_x(p.x);
  s.mutable_position_m()->set_y(p.y);
  s.mutable_position_m()->set_z(p.z);
  s.set_mission_time_s(mission_time_s);
  return s;
}

// Where a UAV flying `path` is at mission time t, by this file's own rule
// and arithmetic: at its first point before the start, at its last after
// the end, in between the segment's polynomial sum_k c_k tau^k.
struct Flight {
  v1::PlanPathResponse path;  // empty trajectory: holding `hold`
  Point hold{};
};

// The order-th derivative (0: position) of a trajectory at t seconds from
// its start (clamped to it), by this file's own Horner sums.
inline Point DerivativeAt(const v1::Trajectory& traj, double t, int order) {
  double tau = std::clamp(t, 0.0, traj.duration_s());
  int k = 0;
  while (k + 1 < traj.segments_size() && tau > traj.segments(k).duration_s()) {
    tau -= traj.segments(k).duration_s();
    ++k;
  }
  const v1::PolynomialSegment& seg = traj.segments(k);
  tau = std::min(tau, seg.duration_s());
  const auto poly = [&](const google::protobuf::RepeatedField<double>& c) {
    double v = 0.0;
    for (int i = c.size() - 1; i >= order; --i) {
      double factor = 1.0;
      for (int j = 0; j < order; ++j) factor *= i - j;
      v = v * tau + factor * c.Get(i);
    }
    return v;
  };
  return {poly(seg.x_coefficients()), poly(seg.y_coefficients()), poly(seg.z_coefficients())};
}

inline Point PositionAt(const Flight& f, double t) {
  const v1::Trajectory& traj = f.path.trajectory();
  if (traj.segments_size() == 0) return f.hold;
  return DerivativeAt(traj, t - f.path.start_mission_s(), 0);
}

inline double EndOf(const Flight& f) {
  return f.path.start_mission_s() + f.path.trajectory().duration_s();
}

// The smallest distance between two flights, sampled at 100 Hz from `from`
// until both have ended.
inline double ClosestApproach(const Flight& a, const Flight& b, double from) {
  const double to = std::max({EndOf(a), EndOf(b), from}) + 0.01;
  double closest = std::numeric_limits<double>::infinity();
  for (double t = from; t <= to; t += 0.01) {
    const Point p = PositionAt(a, t);
    const Point q = PositionAt(b, t);
    closest = std::min(closest, std::hypot(p.x - q.x, p.y - q.y, p.z - q.z));
  }
  return closest;
}

// Flies up to `legs` plans of the single-UAV mission `id` from `start`, each
// from where the last ended, 10 s of mission time apart, calling
// check(path, leg) on each. A plan refused FAILED_PRECONDITION (no safe
// path from there) ends the flight; any other refusal fails the test.
// Returns the plans made.
inline int FlyLegs(v1::MissionService::Stub& stub, const std::string& id, const Point& start,
                   int legs, const std::function<void(const v1::PlanPathResponse&, int)>& check) {
  v1::PlanPathResponse path;
  Point from = start;
  int plans = 0;
  for (int leg = 0; leg < legs; ++leg) {
    const grpc::Status s =
        PlanFor(stub, id, "", At(from, 10.0 * leg), absl::StrCat("p", leg), &path);
    if (!s.ok()) {
      EXPECT_EQ(s.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << s.error_message();
      break;
    }
    ++plans;
    check(path, leg);
    from = PositionAt(Flight{.path = path}, EndOf(Flight{.path = path}));
  }
  return plans;
}

// A test with a folder of its own for a SQLite store (Open), removed after.
class TeamStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           absl::StrCat("oaipp-team-", getpid(), "-",
                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  // A restart test's limits, its store emptied first: snapshots after every
  // measurement (snapshot_every 1: the restart reads a snapshot) or never
  // (0: it replays the log).
  RegistryLimits FreshStore(int snapshot_every) {
    std::filesystem::remove_all(dir_ / "missions.db");
    return {.max_missions = 8, .max_cells_per_mission = 1600, .snapshot_every = snapshot_every};
  }
  std::unique_ptr<MissionStore> Open() {
    auto store = OpenSqliteStore((dir_ / "missions.db").string());
    EXPECT_TRUE(store.ok()) << store.status();
    return *std::move(store);
  }
  // A spec CreateMission must refuse, and the start of its message.
  struct Refusal {
    std::string what;
    v1::MissionSpec spec;
    std::string field;
  };
  // Each refused as INVALID_ARGUMENT naming its field, on a fresh store;
  // then nothing stored: no mission listed, none recovered on a restart.
  void ExpectRefusedAndNothingStored(const std::vector<Refusal>& refusals) {
    const RegistryLimits limits = FreshStore(0);
    std::unique_ptr<MissionStore> store = Open();
    {
      InProcessService s(limits, 2, 64, store.get());
      for (const Refusal& r : refusals) {
        SCOPED_TRACE(r.what);
        grpc::ClientContext context;
        v1::CreateMissionRequest request;
        request.set_mission_id("bad");
        *request.mutable_spec() = r.spec;
        v1::Mission mission;
        const grpc::Status status = s.stub().CreateMission(&context, request, &mission);
        EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
        EXPECT_EQ(status.error_message().rfind(r.field, 0), 0u) << status.error_message();
      }
      grpc::ClientContext context;
      v1::ListMissionsResponse listed;
      ASSERT_TRUE(s.stub().ListMissions(&context, v1::ListMissionsRequest(), &listed).ok());
      EXPECT_EQ(listed.missions_size(), 0);
    }
    InProcessService after(limits, 2, 64, store.get());
    ASSERT_TRUE(after.recovered().ok());
    EXPECT_EQ(*after.recovered(), 0);
  }
  std::filesystem::path dir_;
};

}  // namespace oaipp::server::testing
