// Snapshot bytes: a state comes back exactly (doubles as their bytes, the
// covariance from its lower triangle), and bytes that are not a state this
// server wrote are refused with DataLoss, not restored.
#include "server/store/state_codec.h"

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
  EXPECT_EQ(std::get<ObstacleResult>(back->answers[1].second.result).esdf_voxels_recomputed, 99);
  // Half the matrix: n means + n (n + 1) / 2 covariances, plus a little.
  EXPECT_LT(bytes.size(), (5 + 15) * 8 + 200);
}

TEST(StateCodecTest, BytesThatAreNotAStateAreDataLoss) {
  const std::string bytes = EncodeMissionState(SomeState());
  EXPECT_EQ(DecodeMissionState("not a snapshot").status().code(), absl::StatusCode::kDataLoss);
  EXPECT_EQ(DecodeMissionState(bytes.substr(0, bytes.size() / 2)).status().code(),
            absl::StatusCode::kDataLoss);
}

}  // namespace
}  // namespace oaipp::server
