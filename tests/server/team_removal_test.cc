// Taking a UAV out of its team (RemoveTeamMember, docs/teams.md), through
// the service in process: refused where it cannot be, with the field named
// and nothing changed; answered once per request_id; the removed UAV may not
// plan, its late measurements are still fused; its teammates then plan as
// if it had never flown (a lone UAV's plan, by this file's comparison); and
// the removal comes back after a restart, from the log and from a snapshot.
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "server/store/sqlite_store.h"
#include "tests/server/service_fixture.h"
#include "tests/server/team_fixture.h"

namespace oaipp::server {
namespace {

using testing::At;
using testing::CreateTeam;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using testing::InProcessService;
using testing::PlanFor;
using testing::Point;
using testing::TeamSpec;

// Removes a UAV that has landed (one removed in the air stays an obstacle:
// team_link_test.cc).
grpc::Status Remove(v1::MissionService::Stub& stub, const std::string& mission,
                    const std::string& uav_id, const std::string& request_id,
                    v1::RemoveTeamMemberResponse* out, bool landed = true) {
  grpc::ClientContext context;
  v1::RemoveTeamMemberRequest request;
  request.set_name("missions/" + mission);
  request.set_uav_id(uav_id);
  request.set_request_id(request_id);
  request.set_landed(landed);
  return stub.RemoveTeamMember(&context, request, out);
}

v1::Mission Get(v1::MissionService::Stub& stub, const std::string& mission) {
  grpc::ClientContext context;
  v1::GetMissionRequest request;
  request.set_name("missions/" + mission);
  v1::Mission out;
  const grpc::Status status = stub.GetMission(&context, request, &out);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return out;
}

std::vector<std::string> Ids(const google::protobuf::RepeatedPtrField<std::string>& ids) {
  return {ids.begin(), ids.end()};
}

TEST(TeamRemovalTest, ARemovalIsRefusedWhereItCannotBeAndAnsweredOnce) {
  InProcessService service(RegistryLimits{.max_missions = 8, .max_cells_per_mission = 1600});
  const std::vector<Point> starts = {{-8, 8, 8}, {8, 8, 8}, {-8, -8, 8}};
  v1::Mission out;
  ASSERT_TRUE(CreateTeam(service.stub(), "t", TeamSpec(starts), &out).ok());
  ASSERT_TRUE(CreateTeam(service.stub(), "one", testing::SmallSpec(), &out).ok());
  v1::RemoveTeamMemberResponse removed;

  struct Refusal {
    const char* what;
    std::string mission, uav_id;
    grpc::StatusCode code;
    const char* field;
  };
  for (const Refusal& r : std::vector<Refusal>{
           {"no team", "one", "", grpc::StatusCode::FAILED_PRECONDITION, "uav_id"},
           {"no uav_id", "t", "", grpc::StatusCode::INVALID_ARGUMENT, "uav_id"},
           {"not a member", "t", "zz", grpc::StatusCode::NOT_FOUND, "uav_id"},
           {"no such mission", "nowhere", "a", grpc::StatusCode::NOT_FOUND, "name"}}) {
    const grpc::Status status = Remove(service.stub(), r.mission, r.uav_id, "", &removed);
    EXPECT_EQ(status.error_code(), r.code) << r.what << ": " << status.error_message();
    EXPECT_THAT(status.error_message(), HasSubstr(r.field)) << r.what;
  }
  EXPECT_TRUE(Get(service.stub(), "t").removed_uav_ids().empty());

  ASSERT_TRUE(Remove(service.stub(), "t", "b", "rb", &removed).ok());
  EXPECT_THAT(Ids(removed.flying_uav_ids()), ElementsAre("a", "c"));
  // A retry is answered with the first answer, once c is gone too.
  ASSERT_TRUE(Remove(service.stub(), "t", "c", "rc", &removed).ok());
  EXPECT_THAT(Ids(removed.flying_uav_ids()), ElementsAre("a"));
  ASSERT_TRUE(Remove(service.stub(), "t", "b", "rb", &removed).ok());
  EXPECT_THAT(Ids(removed.flying_uav_ids()), ElementsAre("a", "c"));
  // The same id for another removal is refused.
  EXPECT_EQ(Remove(service.stub(), "t", "a", "rb", &removed).error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
  {
    const grpc::Status again = Remove(service.stub(), "t", "b", "rb2", &removed);
    EXPECT_EQ(again.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
    EXPECT_THAT(again.error_message(), HasSubstr("removed from the team already"));
    const grpc::Status last = Remove(service.stub(), "t", "a", "ra", &removed);
    EXPECT_EQ(last.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
    EXPECT_THAT(last.error_message(), HasSubstr("last one in the team"));
  }
  EXPECT_THAT(Ids(Get(service.stub(), "t").removed_uav_ids()), ElementsAre("b", "c"));

  // b may not plan again; a shot it took before, delivered late, is fused.
  v1::PlanPathResponse path;
  const grpc::Status plan = PlanFor(service.stub(), "t", "b", At(starts[1], 0), "pb", &path);
  EXPECT_EQ(plan.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_THAT(plan.error_message(), HasSubstr("uav_id"));
  grpc::ClientContext context;
  v1::AddMeasurementRequest late = testing::LabelMeasurement("missions/t", 8, 8, 8, 0.5, 0.0);
  late.set_uav_id("b");
  v1::AddMeasurementResponse fused;
  ASSERT_TRUE(service.stub().AddMeasurement(&context, late, &fused).ok());
  EXPECT_EQ(fused.measurements_fused(), 1);
  ASSERT_TRUE(PlanFor(service.stub(), "t", "a", At(starts[0], 0), "pa", &path).ok());
  EXPECT_EQ(path.checked_against_size(), 0);
}

// Once b is removed, a plans exactly as a lone UAV at a's start would (the
// random planner draws the same destinations; its information to rounding,
// as the team's conditioning chain computes it), while with b still in the
// team a's plan counts b's pending shots and expects less.
TEST(TeamRemovalTest, ARemovedMemberNoLongerShapesItsTeammatesPlans) {
  InProcessService service(RegistryLimits{.max_missions = 64, .max_cells_per_mission = 1600});
  const std::vector<Point> starts = {{-3, 8, 8}, {3, 8, 8}};
  bool compared = false;
  for (std::uint32_t seed = 1; seed <= 10 && !compared; ++seed) {
    v1::MissionSpec spec = TeamSpec(starts);
    spec.mutable_planner()->set_kind(v1::PLANNER_KIND_RANDOM);
    spec.mutable_planner()->set_seed(seed);
    v1::MissionSpec lone = spec;
    lone.clear_team();
    lone.clear_min_separation_m();
    *lone.mutable_start() = At(starts[0], 0);
    const std::string kept = absl::StrCat("kept-", seed), gone = absl::StrCat("gone-", seed),
                      alone = absl::StrCat("alone-", seed);
    v1::Mission out;
    ASSERT_TRUE(CreateTeam(service.stub(), kept, spec, &out).ok());
    ASSERT_TRUE(CreateTeam(service.stub(), gone, spec, &out).ok());
    ASSERT_TRUE(CreateTeam(service.stub(), alone, lone, &out).ok());
    v1::PlanPathResponse b, with_b, without_b, by_itself;
    ASSERT_TRUE(PlanFor(service.stub(), kept, "b", At(starts[1], 0), "pb", &b).ok());
    ASSERT_TRUE(PlanFor(service.stub(), gone, "b", At(starts[1], 0), "pb", &b).ok());
    v1::RemoveTeamMemberResponse removed;
    ASSERT_TRUE(Remove(service.stub(), gone, "b", "rb", &removed).ok());
    ASSERT_TRUE(PlanFor(service.stub(), kept, "a", At(starts[0], 0), "pa", &with_b).ok());
    ASSERT_TRUE(PlanFor(service.stub(), gone, "a", At(starts[0], 0), "pa", &without_b).ok());
    ASSERT_TRUE(PlanFor(service.stub(), alone, "", At(starts[0], 0), "pa", &by_itself).ok());

    ASSERT_EQ(with_b.checked_against_size(), 1);
    EXPECT_EQ(with_b.checked_against(0).uav_id(), "b");
    EXPECT_EQ(without_b.checked_against_size(), 0);
    ASSERT_EQ(without_b.control_waypoints_m_size(), by_itself.control_waypoints_m_size());
    for (int i = 0; i < by_itself.control_waypoints_m_size(); ++i) {
      EXPECT_EQ(without_b.control_waypoints_m(i).x(), by_itself.control_waypoints_m(i).x());
      EXPECT_EQ(without_b.control_waypoints_m(i).y(), by_itself.control_waypoints_m(i).y());
      EXPECT_EQ(without_b.control_waypoints_m(i).z(), by_itself.control_waypoints_m(i).z());
    }
    EXPECT_NEAR(without_b.information(), by_itself.information(),
                1e-9 * std::max(1.0, by_itself.information()));
    if (by_itself.information() <= 0.0 || b.measurement_poses_size() < 2) continue;
    if (with_b.control_waypoints_m_size() != by_itself.control_waypoints_m_size()) continue;
    EXPECT_LT(with_b.information(), 0.9 * by_itself.information()) << seed;
    compared = true;
  }
  EXPECT_TRUE(compared) << "no seed in 1-10 gave a a path that b's shots could take from";
}

class TeamRemovalRestartTest : public testing::TeamStoreTest {};

TEST_F(TeamRemovalRestartTest, ARemovalComesBackFromTheLogAndFromASnapshot) {
  const std::vector<Point> starts = {{-8, 8, 8}, {8, 8, 8}, {-8, -8, 8}};
  for (const int snapshot_every : {0, 1}) {
    SCOPED_TRACE(snapshot_every == 0 ? "from the log" : "from a snapshot");
    const RegistryLimits limits = FreshStore(snapshot_every);
    std::unique_ptr<MissionStore> store = Open();
    v1::RemoveTeamMemberResponse first;
    {
      InProcessService before(limits, 2, 64, store.get());
      v1::Mission team;
      ASSERT_TRUE(CreateTeam(before.stub(), "t", TeamSpec(starts), &team).ok());
      v1::PlanPathResponse b;
      ASSERT_TRUE(PlanFor(before.stub(), "t", "b", At(starts[1], 0), "pb", &b).ok());
      ASSERT_TRUE(Remove(before.stub(), "t", "b", "rb", &first).ok());
      // A measurement after the removal: with snapshot_every 1 the snapshot
      // then covers the removal, which the restart reads from it.
      grpc::ClientContext context;
      v1::AddMeasurementRequest shot = testing::LabelMeasurement("missions/t", -8, 8, 8, 0.5, 0.0);
      shot.set_uav_id("a");
      shot.set_request_id("ma");
      v1::AddMeasurementResponse fused;
      ASSERT_TRUE(before.stub().AddMeasurement(&context, shot, &fused).ok());
      if (snapshot_every > 0) before.registry().FlushSnapshots();
    }
    InProcessService after(limits, 2, 64, store.get());
    ASSERT_TRUE(after.recovered().ok());
    EXPECT_THAT(Ids(Get(after.stub(), "t").removed_uav_ids()), ElementsAre("b"));
    v1::RemoveTeamMemberResponse retried;
    ASSERT_TRUE(Remove(after.stub(), "t", "b", "rb", &retried).ok());
    EXPECT_EQ(retried.SerializeAsString(), first.SerializeAsString());
    v1::PlanPathResponse path;
    EXPECT_EQ(PlanFor(after.stub(), "t", "b", At(starts[1], 0), "pb2", &path).error_code(),
              grpc::StatusCode::NOT_FOUND);
    ASSERT_TRUE(PlanFor(after.stub(), "t", "c", At(starts[2], 0), "pc", &path).ok());
    ASSERT_EQ(path.checked_against_size(), 1);
    EXPECT_EQ(path.checked_against(0).uav_id(), "a");
  }
}

}  // namespace
}  // namespace oaipp::server
