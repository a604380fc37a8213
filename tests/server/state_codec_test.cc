// Snapshot bytes: a state comes back exactly (doubles as their bytes, the
// covariance from its lower triangle), and bytes that are not a state this
// server wrote are refused with DataLoss, not restored.
#include "server/store/state_codec.h"

#include <vector>

#include "core/mapping/gmrf_prior.h"
#include "oaipp/store/mission_state.pb.h"

#include "gtest/gtest.h"

namespace oaipp::server {
namespace {

MissionState SomeState() {
  MissionState s;
  s.sequence = 41;
  const int n = 5;
  s.mean = Eigen::VectorXd::LinSpaced(n, -0.3, 0.7);
  Eigen::MatrixXd a = Eigen::MatrixXd::Random(n, n);
  s.covariance = a * a.transpose();  // symmetric bit for bit
  s.covered_cells = {0, 3};
  s.measurements_fused = 12;
  s.mission_time_s = 33.25;
  s.paths_planned = 4;
  s.planner_state = std::string("lawn\0mower 3", 12);
  s.answers.emplace_back(
      "m1", RememberedAnswer{
                "fp-m1",
                MeasurementResult{.cells_fused = 7, .trace = 1.0 / 3.0, .measurements_fused = 1}});
  s.answers.emplace_back("o1", RememberedAnswer{"", ObstacleResult{.obstacle_count = 2,
                                                                   .esdf_voxels_recomputed = 99}});
  s.removed_uav_ids = {"c", "b"};
  s.landed_uav_ids = {"b"};
  s.last_shot_s = {{"a", 7.5}};
  s.fused_shot_s = {{"a", {1.5, 7.5}}, {"d", {}}};
  return s;
}

TEST(StateCodecTest, AStateComesBackExactly) {
  const MissionState s = SomeState();
  const std::string bytes = EncodeMissionState(s);
  absl::StatusOr<MissionState> back = DecodeMissionState(bytes);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->sequence, 41);
  EXPECT_TRUE(back->mean == s.mean);
  EXPECT_TRUE(back->covariance == s.covariance);
  EXPECT_EQ(back->covered_cells, s.covered_cells);
  EXPECT_EQ(back->measurements_fused, 12);
  EXPECT_EQ(back->mission_time_s, 33.25);
  EXPECT_EQ(back->paths_planned, 4);
  EXPECT_EQ(back->planner_state, s.planner_state);
  ASSERT_EQ(back->answers.size(), 2u);
  EXPECT_EQ(back->answers[0].first, "m1");
  EXPECT_EQ(back->answers[0].second.fingerprint, "fp-m1");
  EXPECT_EQ(std::get<MeasurementResult>(back->answers[0].second.result).trace, 1.0 / 3.0);
  // Written before the field existed (0): a dense map's trace was current.
  EXPECT_EQ(std::get<MeasurementResult>(back->answers[0].second.result).trace_measurements_fused,
            1);
  EXPECT_EQ(std::get<ObstacleResult>(back->answers[1].second.result).esdf_voxels_recomputed, 99);
  EXPECT_EQ(back->removed_uav_ids, s.removed_uav_ids);
  EXPECT_EQ(back->landed_uav_ids, s.landed_uav_ids);
  EXPECT_EQ(back->last_shot_s, s.last_shot_s);
  EXPECT_EQ(back->fused_shot_s, s.fused_shot_s);
  // Half the matrix: n means + n (n + 1) / 2 covariances, plus a little.
  EXPECT_LT(bytes.size(), (5 + 15) * 8 + 240);
}

TEST(StateCodecTest, BytesThatAreNotAStateAreDataLoss) {
  const std::string bytes = EncodeMissionState(SomeState());
  EXPECT_EQ(DecodeMissionState("not a snapshot").status().code(), absl::StatusCode::kDataLoss);
  EXPECT_EQ(DecodeMissionState(bytes.substr(0, bytes.size() / 2)).status().code(),
            absl::StatusCode::kDataLoss);
}

// A sparse map's state: the two vectors of additions, no mean or
// covariance, and an answer that says how far its trace lagged.
TEST(StateCodecTest, ASparseMapsStateComesBackExactly) {
  MissionState s = SomeState();
  s.mean.resize(0);
  s.covariance.resize(0, 0);
  s.added_precision = Eigen::VectorXd::LinSpaced(6, 0.0, 2.5);
  s.added_information = Eigen::VectorXd::LinSpaced(6, -1.0, 1.0 / 3.0);
  std::get<MeasurementResult>(s.answers[0].second.result).trace_measurements_fused = 0;
  s.answers.emplace_back("m2",
                         RememberedAnswer{"", MeasurementResult{.cells_fused = 3,
                                                                .trace = 2.0,
                                                                .measurements_fused = 9,
                                                                .trace_measurements_fused = 7}});
  const std::string bytes = EncodeMissionState(s);
  absl::StatusOr<MissionState> back = DecodeMissionState(bytes);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->mean.size(), 0);
  EXPECT_EQ(back->covariance.size(), 0);
  EXPECT_TRUE(back->added_precision == s.added_precision);
  EXPECT_TRUE(back->added_information == s.added_information);
  EXPECT_EQ(std::get<MeasurementResult>(back->answers[2].second.result).trace_measurements_fused,
            7);
  // On a sparse map 0 is an answer whose trace included no measurement yet
  // (the background refresh had not caught up): it stays 0.
  EXPECT_EQ(std::get<MeasurementResult>(back->answers[0].second.result).trace_measurements_fused,
            0);
  // No trace was captured: none comes back (the restore computes it).
  EXPECT_FALSE(back->trace.has_value());

  // A captured trace comes back with the measurements it includes; one
  // that is negative, or ahead of the measurements fused, is corrupt.
  s.trace = 12.75;
  s.trace_measurements_fused = s.measurements_fused - 1;
  back = DecodeMissionState(EncodeMissionState(s));
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->trace, 12.75);
  EXPECT_EQ(back->trace_measurements_fused, s.measurements_fused - 1);
  // One computed on another fit of the sparse prior (a later build's, or an
  // earlier one's) is not this map's trace: none comes back, and the map
  // and its measurements do. Nor does one written where builds before the
  // fit was recorded wrote it (on the first fit), and this build does not
  // write there, so that those builds compute their own.
  store::MissionState written;
  ASSERT_TRUE(written.ParseFromString(EncodeMissionState(s)));
  EXPECT_FALSE(written.has_trace());
  ASSERT_EQ(written.trace_prior_fit(), kGmrfFitVersion);
  std::vector<store::MissionState> others(4, written);
  others[0].set_trace_prior_fit(0);
  others[1].set_trace_prior_fit(kGmrfFitVersion - 1);
  others[2].set_trace_prior_fit(kGmrfFitVersion + 1);
  others[3].clear_fitted_trace();
  others[3].clear_trace_prior_fit();
  others[3].set_trace(12.75);
  for (std::size_t i = 0; i < others.size(); ++i) {
    absl::StatusOr<MissionState> older = DecodeMissionState(others[i].SerializeAsString());
    ASSERT_TRUE(older.ok()) << older.status();
    EXPECT_FALSE(older->trace.has_value()) << i;
    EXPECT_EQ(older->added_precision, s.added_precision);
    EXPECT_EQ(older->measurements_fused, s.measurements_fused);
  }
  for (const auto& [trace, included] :
       {std::pair{-1.0, s.measurements_fused}, std::pair{1.0, s.measurements_fused + 1}}) {
    MissionState wrong = s;
    wrong.trace = trace;
    wrong.trace_measurements_fused = included;
    EXPECT_EQ(DecodeMissionState(EncodeMissionState(wrong)).status().code(),
              absl::StatusCode::kDataLoss)
        << trace << " " << included;
  }

  // The two vectors must match the cell count, and a state holds one map.
  store::MissionState bad;
  ASSERT_TRUE(bad.ParseFromString(bytes));
  bad.mutable_added_information()->resize(5 * 8);
  EXPECT_EQ(DecodeMissionState(bad.SerializeAsString()).status().code(),
            absl::StatusCode::kDataLoss);
  ASSERT_TRUE(bad.ParseFromString(bytes));
  bad.set_mean(std::string(6 * 8, '\0'));
  EXPECT_EQ(DecodeMissionState(bad.SerializeAsString()).status().code(),
            absl::StatusCode::kDataLoss);
}

// A team's committed trajectories come back with their stamps; one without
// its uav_id is not a state this server wrote.
TEST(StateCodecTest, ATeamsCommittedTrajectoriesComeBack) {
  PolynomialTrajectory::SegmentCoefficients c = PolynomialTrajectory::SegmentCoefficients::Zero();
  c.row(0) << 1.0, 2.0, 8.0;
  c.row(1) << 0.5, 0.0, 0.0;
  PlannedPath path{.trajectory = *PolynomialTrajectory::FromCoefficients({4.0}, {c})};
  path.team = {.uav_id = "north",
               .plan_version = 7,
               .start_mission_s = 12.5,
               .checked_against = {{"south", 6}, {"west", 0}}};
  MissionState s = SomeState();
  s.committed.push_back(path);
  absl::StatusOr<MissionState> back = DecodeMissionState(EncodeMissionState(s));
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->committed.size(), 1u);
  const PlannedPath& got = back->committed.front();
  EXPECT_EQ(got.team.uav_id, "north");
  EXPECT_EQ(got.team.plan_version, 7);
  EXPECT_EQ(got.team.start_mission_s, 12.5);
  EXPECT_EQ(got.team.checked_against, path.team.checked_against);
  EXPECT_EQ(got.trajectory.Position(2.0), Vec3(2.0, 2.0, 8.0));

  s.committed.front().team.uav_id.clear();
  EXPECT_EQ(DecodeMissionState(EncodeMissionState(s)).status().code(), absl::StatusCode::kDataLoss);
}

}  // namespace
}  // namespace oaipp::server
