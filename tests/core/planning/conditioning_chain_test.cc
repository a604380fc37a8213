#include "core/planning/conditioning_chain.h"

#include <random>
#include <vector>

#include "Eigen/Cholesky"
#include "core/mapping/gp_map.h"
#include "gtest/gtest.h"

namespace oaipp {
namespace {

// The chain's keys for the covariances below: a map at version 1, and a
// block of the same version's field elsewhere (another covariance).
constexpr CovarianceKey kField{.map_version = 1, .rows = 12, .cols = 12};
constexpr CovarianceKey kWindow{
    .map_version = 1, .first_row = 2, .first_col = 3, .rows = 12, .cols = 12};

// The paper's prior on side x side cells of 0.75 m.
struct Field {
  FieldGrid grid;
  Eigen::MatrixXd prior;
};
Field Prior(int side) {
  auto grid = FieldGrid::Create({0, 0}, side, side, 0.75);
  EXPECT_TRUE(grid.ok());
  auto map = GpMap::Create(*grid, GpParams::PaperPreset(0.75));
  EXPECT_TRUE(map.ok());
  return {*grid, map->Covariance()};
}

// The reference, written out apart from the code under test: the
// information form (P^-1 + H^T R^-1 H)^-1 with one row of H per observed
// cell of every pose.
Eigen::MatrixXd Reference(const Eigen::MatrixXd& p, const std::vector<PoseObservation>& poses) {
  const Eigen::Index n = p.rows();
  Eigen::MatrixXd info = p.llt().solve(Eigen::MatrixXd::Identity(n, n));
  for (const PoseObservation& pose : poses) {
    for (int c : pose.cells) info(c, c) += 1.0 / pose.variance;
  }
  return info.llt().solve(Eigen::MatrixXd::Identity(n, n));
}

std::vector<PoseObservation> Footprints(const FieldGrid& grid, int count, double min_var,
                                        double max_var, std::mt19937& rng) {
  std::uniform_real_distribution<double> x(grid.min_W().x(), grid.max_W().x()),
      y(grid.min_W().y(), grid.max_W().y()), size(2.0, 6.0), var(min_var, max_var);
  std::vector<PoseObservation> poses(static_cast<std::size_t>(count));
  for (PoseObservation& pose : poses) {
    pose.cells = grid.CellsInRectangle({x(rng), y(rng)}, {size(rng), size(rng)});
    pose.variance = var(rng);
    pose.scored = false;
  }
  return poses;
}

double MaxAbs(const Eigen::MatrixXd& m) { return m.cwiseAbs().maxCoeff(); }

TEST(RemovePosesTest, UndoesFusePosesInAnyOrder) {
  const Field field = Prior(14);
  const FieldGrid& grid = field.grid;
  const Eigen::MatrixXd prior = field.prior;
  std::mt19937 rng(3);
  const std::vector<PoseObservation> a = Footprints(grid, 4, 0.05, 0.5, rng);
  const std::vector<PoseObservation> b = Footprints(grid, 3, 0.05, 0.5, rng);
  std::vector<PoseObservation> both = a;
  both.insert(both.end(), b.begin(), b.end());
  Eigen::MatrixXd p = prior;
  FusePoses(DenseBackend(), both, p);
  ASSERT_LT(MaxAbs(p - Reference(prior, both)), 1e-10 * MaxAbs(prior));
  // Taking a (fused first) back out leaves the prior conditioned on b.
  ASSERT_TRUE(RemovePoses(DenseBackend(), a, ConditioningChain::kMaxAmplification, p).ok());
  EXPECT_LT(MaxAbs(p - Reference(prior, b)), 1e-10 * MaxAbs(prior));
  ASSERT_TRUE(RemovePoses(DenseBackend(), b, ConditioningChain::kMaxAmplification, p).ok());
  EXPECT_LT(MaxAbs(p - prior), 1e-10 * MaxAbs(prior));
}

TEST(RemovePosesTest, RefusesPosesTheCovarianceDoesNotHold) {
  const Field field = Prior(10);
  const FieldGrid& grid = field.grid;
  Eigen::MatrixXd p = field.prior;
  const Eigen::MatrixXd before = p;
  std::mt19937 rng(5);
  // Never fused: R - P_KK has the prior variance (1) against noise 0.1.
  const std::vector<PoseObservation> poses = Footprints(grid, 2, 0.1, 0.1, rng);
  const absl::Status s = RemovePoses(DenseBackend(), poses, 1e4, p);
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition) << s;
  EXPECT_EQ(p, before);
}

// A team of 8 in the order of a planning round: each plan conditions on
// every other member's pending shots and its own start shot, then commits
// new shots. Every result equals the reference to 1e-9 of the prior's
// scale, and most come incrementally.
TEST(ConditioningChainTest, ATeamsPlansEqualTheReferenceAlongTheChain) {
  const Field field = Prior(16);
  const FieldGrid& grid = field.grid;
  const Eigen::MatrixXd prior = field.prior;
  std::mt19937 rng(11);
  constexpr int kTeam = 8;
  std::vector<std::vector<PoseObservation>> pending(kTeam);
  for (auto& shots : pending) shots = Footprints(grid, 3, 0.02, 0.4, rng);
  ConditioningChain chain;
  double worst = 0.0;
  for (int plan = 0; plan < 40; ++plan) {
    const int u = plan % kTeam;
    std::vector<PoseObservation> prefix;
    for (int v = 0; v < kTeam; ++v) {
      if (v != u) prefix.insert(prefix.end(), pending[v].begin(), pending[v].end());
    }
    const std::vector<PoseObservation> start = Footprints(grid, 1, 0.02, 0.4, rng);
    prefix.push_back(start[0]);
    auto p_c = chain.Condition(prior, kField, prefix, DenseBackend());
    ASSERT_TRUE(p_c.ok()) << p_c.status();
    worst = std::max(worst, MaxAbs(**p_c - Reference(prior, prefix)) / MaxAbs(prior));
    pending[static_cast<std::size_t>(u)] = Footprints(grid, 3, 0.02, 0.4, rng);
  }
  EXPECT_LT(worst, 1e-9);
  const ConditioningChain::Stats stats = chain.stats();
  EXPECT_EQ(stats.fresh + stats.incremental + stats.reused, 40);
  // The first, and one after each kMaxSteps incremental ones.
  EXPECT_EQ(stats.fresh, 2);
  EXPECT_EQ(stats.incremental, 38);
}

TEST(ConditioningChainTest, ANewSourceOrTheSamePosesAgain) {
  const Field field = Prior(12);
  const FieldGrid& grid = field.grid;
  const Eigen::MatrixXd prior = field.prior;
  std::mt19937 rng(2);
  const std::vector<PoseObservation> poses = Footprints(grid, 6, 0.05, 0.5, rng);
  ConditioningChain chain;
  auto first = chain.Condition(prior, kField, poses, DenseBackend());
  ASSERT_TRUE(first.ok());
  auto again = chain.Condition(prior, kField, poses, DenseBackend());
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(first->get(), again->get());
  // Another covariance (the same version's window elsewhere): afresh, from it.
  Eigen::MatrixXd other = prior;
  FusePoses(DenseBackend(), Footprints(grid, 2, 0.1, 0.2, rng), other);
  auto from_other = chain.Condition(other, kWindow, poses, DenseBackend());
  ASSERT_TRUE(from_other.ok());
  EXPECT_LT(MaxAbs(**from_other - Reference(other, poses)), 1e-10);
  EXPECT_EQ(chain.stats().fresh, 2);
  EXPECT_EQ(chain.stats().reused, 1);
  EXPECT_EQ(chain.bytes(), 8 * prior.size());
}

TEST(ConditioningChainTest, AResultHeldByAPlanIsNotChanged) {
  const Field field = Prior(12);
  const FieldGrid& grid = field.grid;
  const Eigen::MatrixXd prior = field.prior;
  std::mt19937 rng(4);
  std::vector<PoseObservation> poses = Footprints(grid, 8, 0.05, 0.5, rng);
  ConditioningChain chain;
  auto held = chain.Condition(prior, kField, poses, DenseBackend());
  ASSERT_TRUE(held.ok());
  const Eigen::MatrixXd copy = **held;
  poses.pop_back();
  auto next = chain.Condition(prior, kField, poses, DenseBackend());
  ASSERT_TRUE(next.ok());
  EXPECT_EQ(chain.stats().incremental, 1);
  EXPECT_NE(held->get(), next->get());
  EXPECT_EQ(**held, copy);
  EXPECT_LT(MaxAbs(**next - Reference(prior, poses)), 1e-10);
}

// Shots far more certain than the prior: removing them would lose too many
// digits, so the chain conditions afresh, and stays exact.
TEST(ConditioningChainTest, NearCertainShotsAreConditionedAfresh) {
  const Field field = Prior(12);
  const FieldGrid& grid = field.grid;
  const Eigen::MatrixXd prior = field.prior;
  std::mt19937 rng(6);
  std::vector<PoseObservation> poses = Footprints(grid, 6, 1e-6, 1e-6, rng);
  const std::vector<PoseObservation> more = Footprints(grid, 1, 0.1, 0.1, rng);
  ConditioningChain chain;
  ASSERT_TRUE(chain.Condition(prior, kField, poses, DenseBackend()).ok());
  poses.erase(poses.begin());
  poses.push_back(more[0]);
  auto p_c = chain.Condition(prior, kField, poses, DenseBackend());
  ASSERT_TRUE(p_c.ok());
  EXPECT_EQ(chain.stats().fresh, 2);
  EXPECT_EQ(chain.stats().incremental, 0);
  EXPECT_LT(MaxAbs(**p_c - Reference(prior, poses)), 1e-9);
}

}  // namespace
}  // namespace oaipp
