// Missions with a prior map (GpSpec.prior_map; docs/method.md §3.3) through
// the service: each backend's map against a dense Kalman filter run here
// from the same prior mean, the map after a restart (from the log and from a
// snapshot) bit for bit, the refusals, and the first plan drawn towards the
// prior's mass.
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "api/spec.h"
#include "core/mapping/camera.h"
#include "core/mapping/gmrf_prior.h"
#include "core/mapping/gp_map.h"
#include "gtest/gtest.h"
#include "tests/core/mapping/gmrf_reference.h"
#include "tests/server/label_shots.h"
#include "tests/server/service_fixture.h"
#include "tests/server/team_fixture.h"

namespace oaipp::server {
namespace {

using ::oaipp::testing::DenseFieldCovariance;
using testing::AddLabelShots;
using testing::CreateWithSpec;
using testing::FuseAsTheSmallMissionWould;
using testing::InProcessService;
using testing::LabelShot;
using testing::SmallSpec;

// The small field: 20 x 20 cells of 0.75 m from (-7.5, -7.5); cell
// (row, col) is centred at x = -7.5 + 0.75 (col + 0.5), y likewise.
constexpr int kSide = 20;

// A lost-person map in label units on a square field of `side` cells of
// 0.75 m centred on the origin: 0.02 everywhere and a bump of 0.9 with a
// 2 m spread around (cx, cy), row-major along y.
std::vector<double> BumpPrior(double cx, double cy, int side = kSide) {
  const auto centre = [side](int i) { return 0.75 * (i + 0.5 - 0.5 * side); };
  std::vector<double> values;
  for (int row = 0; row < side; ++row) {
    for (int col = 0; col < side; ++col) {
      const double dx = centre(col) - cx, dy = centre(row) - cy;
      values.push_back(0.02 + 0.9 * std::exp(-(dx * dx + dy * dy) / (2 * 2.0 * 2.0)));
    }
  }
  return values;
}

v1::MissionSpec PriorSpec(v1::MapBackend backend, const std::vector<double>& prior) {
  v1::MissionSpec spec = SmallSpec();
  spec.mutable_field()->set_map_backend(backend);
  v1::PriorMap& map = *spec.mutable_gp()->mutable_prior_map();
  map.mutable_values()->Assign(prior.begin(), prior.end());
  return spec;
}

// Labelled shots over the small field: (x, y, altitude, label).
const LabelShot kPriorShots[] = {{-4, 4, 8, 0.0}, {3, 3, 12, 1.0}, {4, 4, 5, 0.0}, {5, -5, 3, 1.0}};

v1::GetMapResponse PriorMapOf(v1::MissionService::Stub& stub, const std::string& name) {
  grpc::ClientContext context;
  v1::GetMapRequest request;
  request.set_name(name);
  request.set_include_cells(true);
  request.set_include_prior(true);
  v1::GetMapResponse map;
  const grpc::Status status = stub.GetMap(&context, request, &map);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return map;
}

// What the mission's map should be: a dense Kalman filter run here from the
// prior map as its mean and the backend's prior covariance (the dense
// backend's P0, or the sparse prior's covariance over the field), fed the
// ground under building b1 (x in [-1, 1], y in [-4, 0]) as near-certain
// zeros and then kPriorShots with the paper's noise. On the sparse prior the
// field's marginal is what the lattice's margin leaves it, so the margin's
// mean never enters.
GpMap ReferenceMap(const api::MissionConfig& config, const std::vector<double>& prior,
                   bool sparse) {
  const FieldGrid grid = *config.MakeGrid();
  Eigen::MatrixXd covariance;
  if (sparse) {
    const absl::StatusOr<GmrfPrior> gmrf = MakeGmrfPrior(grid, config.gp);
    EXPECT_TRUE(gmrf.ok()) << gmrf.status();
    covariance = DenseFieldCovariance(*gmrf);
  } else {
    covariance = *PriorCovariance(grid, config.gp);
  }
  absl::StatusOr<GpMap> map = GpMap::FromPrior(
      grid, Eigen::Map<const Eigen::VectorXd>(prior.data(), std::ssize(prior)), covariance);
  EXPECT_TRUE(map.ok()) << map.status();
  FuseAsTheSmallMissionWould(*map, config.noise, kPriorShots);
  return *std::move(map);
}

TEST(PriorMapTest, EachBackendsMapIsAKalmanFilterStartedFromThePriorMap) {
  const std::vector<double> prior = BumpPrior(4, 4);
  for (const v1::MapBackend backend : {v1::MAP_BACKEND_DENSE, v1::MAP_BACKEND_SPARSE}) {
    const bool sparse = backend == v1::MAP_BACKEND_SPARSE;
    SCOPED_TRACE(sparse ? "sparse" : "dense");
    InProcessService s;
    const v1::MissionSpec spec = PriorSpec(backend, prior);
    ASSERT_TRUE(CreateWithSpec(s.stub(), "p", spec).ok());
    // Before any shot the map's mean is the prior map, but under the
    // building (near-certain zeros) and where the building's cells pull.
    const v1::GetMapResponse start = PriorMapOf(s.stub(), "missions/p");
    ASSERT_EQ(start.prior_mean_size(), kSide * kSide);
    EXPECT_TRUE(std::equal(prior.begin(), prior.end(), start.prior_mean().begin()));
    AddLabelShots(s.stub(), "missions/p", kPriorShots);
    const v1::GetMapResponse got = PriorMapOf(s.stub(), "missions/p");
    const GpMap want = ReferenceMap(*api::MissionSpecToConfig(spec), prior, sparse);
    ASSERT_EQ(got.mean_size(), want.num_cells());
    double mean_error = 0.0, variance_error = 0.0, moved = 0.0;
    for (int i = 0; i < want.num_cells(); ++i) {
      mean_error = std::max(mean_error, std::abs(got.mean(i) - want.Mean()[i]));
      variance_error = std::max(variance_error, std::abs(got.variance(i) - want.Variance(i)));
      moved = std::max(moved, std::abs(got.mean(i) - prior[i]));
    }
    // Relative to the prior's variance (e^0.6): both filters are exact.
    EXPECT_LT(mean_error, 1e-9 * std::exp(0.6));
    EXPECT_LT(variance_error, 1e-9 * std::exp(0.6));
    EXPECT_GT(moved, 0.1);  // the shots did move the map
  }
}

class PriorMapRestartTest : public testing::TeamStoreTest {};

// The prior map comes back from the store bit for bit (GetMap's prior_mean
// and the spec's values), and so does the map built on it, after a restart
// that replays the log and after one that reads a snapshot, on each backend.
TEST_F(PriorMapRestartTest, APriorMapSurvivesARestartBitForBit) {
  const std::vector<double> prior = BumpPrior(-3, -5);
  for (const v1::MapBackend backend : {v1::MAP_BACKEND_DENSE, v1::MAP_BACKEND_SPARSE}) {
    for (const int snapshot_every : {0, 1}) {
      SCOPED_TRACE(::testing::Message()
                   << (backend == v1::MAP_BACKEND_SPARSE ? "sparse" : "dense")
                   << (snapshot_every == 0 ? ", from the log" : ", from a snapshot"));
      const RegistryLimits limits = FreshStore(snapshot_every);
      std::unique_ptr<MissionStore> store = Open();
      v1::GetMapResponse before;
      {
        InProcessService first(limits, 2, 64, store.get());
        ASSERT_TRUE(CreateWithSpec(first.stub(), "p", PriorSpec(backend, prior)).ok());
        AddLabelShots(first.stub(), "missions/p", kPriorShots);
        if (snapshot_every > 0) first.registry().FlushSnapshots();
        before = PriorMapOf(first.stub(), "missions/p");
      }
      InProcessService after(limits, 2, 64, store.get());
      ASSERT_TRUE(after.recovered().ok());
      EXPECT_EQ(*after.recovered(), 1);
      const v1::GetMapResponse again = PriorMapOf(after.stub(), "missions/p");
      ASSERT_EQ(again.prior_mean_size(), std::ssize(prior));
      EXPECT_TRUE(std::equal(prior.begin(), prior.end(), again.prior_mean().begin()));
      ASSERT_EQ(again.mean_size(), before.mean_size());
      EXPECT_TRUE(std::equal(before.mean().begin(), before.mean().end(), again.mean().begin()));
      EXPECT_TRUE(
          std::equal(before.variance().begin(), before.variance().end(), again.variance().begin()));
      grpc::ClientContext context;
      v1::GetMissionRequest get;
      get.set_name("missions/p");
      v1::Mission mission;
      ASSERT_TRUE(after.stub().GetMission(&context, get, &mission).ok());
      const v1::PriorMap& kept = mission.spec().gp().prior_map();
      ASSERT_EQ(kept.values_size(), std::ssize(prior));
      EXPECT_TRUE(std::equal(prior.begin(), prior.end(), kept.values().begin()));
      EXPECT_FALSE(mission.spec().gp().has_prior_mean());
    }
  }
}

// A wrong map is refused naming the field, and nothing is stored: the
// mission does not exist, before or after a restart.
TEST_F(PriorMapRestartTest, ABadPriorMapIsRefusedNamingTheFieldAndNothingIsStored) {
  struct Bad {
    std::string what;
    std::vector<double> values;
    v1::PriorMapUnits units;
    std::string field;
  };
  std::vector<double> negative = BumpPrior(0, 0);
  negative[45] = -0.5;
  std::vector<double> not_a_number = BumpPrior(0, 0);
  not_a_number[7] = std::nan("");
  const std::vector<Bad> bad = {
      {"one row short", std::vector<double>(kSide * (kSide - 1), 0.1),
       v1::PRIOR_MAP_UNITS_LABEL_MEAN,
       "spec.gp.prior_map.values: 380 values for a field of 20 x 20"},
      {"negative", negative, v1::PRIOR_MAP_UNITS_LABEL_MEAN, "spec.gp.prior_map.values[45]: "},
      {"not a number", not_a_number, v1::PRIOR_MAP_UNITS_LABEL_MEAN,
       "spec.gp.prior_map.values[7]: "},
      {"probabilities of two people", std::vector<double>(kSide * kSide, 2.0 / (kSide * kSide)),
       v1::PRIOR_MAP_UNITS_PROBABILITY, "spec.gp.prior_map.values: probabilities sum to 2"},
  };
  std::vector<Refusal> refusals;
  for (const Bad& b : bad) {
    v1::MissionSpec spec = PriorSpec(v1::MAP_BACKEND_DENSE, b.values);
    spec.mutable_gp()->mutable_prior_map()->set_units(b.units);
    refusals.push_back({b.what, spec, b.field});
  }
  ExpectRefusedAndNothingStored(refusals);
}

// The first plan from the field's centre goes towards the prior's mass: on
// the default 30 x 30 m field with the bump 8.5 m out along each diagonal in
// turn, the plan's shots lie nearer the bump than the start does, and
// nearer it than the shots of the plan for the opposite corner.
TEST(PriorMapTest, TheFirstPlanGoesTowardsThePriorsMass) {
  const Vec2 corners[] = {{6, 6}, {-6, -6}, {6, -6}, {-6, 6}};
  std::vector<Vec2> centroids;
  InProcessService s({.max_missions = 8, .max_cells_per_mission = 1600});
  for (int k = 0; k < 4; ++k) {
    v1::MissionSpec spec;
    spec.set_preset("paper");
    spec.mutable_planner()->set_seed(5);
    spec.mutable_planner()->set_generations(10);  // the greedy start and a short search
    v1::PriorMap& map = *spec.mutable_gp()->mutable_prior_map();
    for (double v : BumpPrior(corners[k].x(), corners[k].y(), 40)) map.add_values(v);
    spec.mutable_start()->mutable_position_m()->set_z(10);
    const std::string id = absl::StrCat("corner", k);
    ASSERT_TRUE(CreateWithSpec(s.stub(), id, spec).ok());
    v1::PlanPathRequest request;
    request.set_name("missions/" + id);
    request.mutable_state()->mutable_position_m()->set_z(10);
    grpc::ClientContext context;
    v1::PlanPathResponse plan;
    const grpc::Status status = s.stub().PlanPath(&context, request, &plan);
    ASSERT_TRUE(status.ok()) << status.error_message();
    ASSERT_GT(plan.measurement_poses_size(), 1);
    Vec2 sum = Vec2::Zero();
    for (const v1::MeasurementPose& pose : plan.measurement_poses()) {
      sum += Vec2(pose.position_m().x(), pose.position_m().y());
    }
    centroids.push_back(sum / plan.measurement_poses_size());
  }
  for (int k = 0; k < 4; ++k) {
    SCOPED_TRACE(absl::StrCat("bump at (", corners[k].x(), ", ", corners[k].y(),
                              "), shots' centre (", centroids[k].x(), ", ", centroids[k].y(), ")"));
    const int opposite = k ^ 1;  // 0 <-> 1, 2 <-> 3
    EXPECT_LT((centroids[k] - corners[k]).norm(), corners[k].norm() - 1.0);
    EXPECT_LT((centroids[k] - corners[k]).norm(), (centroids[opposite] - corners[k]).norm() - 2.0);
  }
}

}  // namespace
}  // namespace oaipp::server
