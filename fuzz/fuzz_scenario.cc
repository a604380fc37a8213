// libFuzzer target: scenario files of the simulation client (sim/scenario.h,
// JSON in protobuf's mapping of oaipp.v1.Scenario), and what the client does
// with one that parses: Simulation::Create, the detector, labels and metrics
// at the start position, a short flight, and E3's RandomWorld
// (client/cli/client_main.cc runs them in that order).
//
// What aborts (so libFuzzer keeps the input as a crash):
//  - any sanitizer report, or a hang past libFuzzer's -timeout;
//  - a refusal that is not InvalidArgument "fuzz.json:..." (ParseScenario
//    documents "SOURCE:LINE:COLUMN: ..." and "SOURCE: FIELD: ..."), or one
//    whose message does not survive api::SafeMessage's bounds;
//  - a parsed scenario whose JSON (protobuf's own printer) ParseScenario
//    refuses or reads back differently;
//  - Simulation::Create failing with a code it does not document, or a
//    detector box that breaks PixelBox::Validate, which Detect promises;
//  - RandomWorld returning a world whose mission no longer converts.
//
// Size guards, as in fuzz_requests.cc: the simulation is built only when
// its ESDF has at most kMaxFuzzVoxels voxels, voxels x (obstacles + 1) stays
// under kMaxFuzzVoxelWork, and cells x (targets + obstacles + 1) stays under
// kMaxFuzzCellWork (each target is rasterised over the grid and the truth
// labels test every cell against every obstacle). Detect is skipped when the
// false-positive rate at the start is between 1e4 and int's range: that many
// boxes are merely slow, while a rate past int's range tests the draw itself.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "api/mission_config.h"
#include "api/spec.h"
#include "core/trajectory/polynomial_trajectory.h"
#include "fuzz/fuzz_util.h"
#include "google/protobuf/stubs/logging.h"
#include "google/protobuf/util/field_comparator.h"
#include "google/protobuf/util/json_util.h"
#include "google/protobuf/util/message_differencer.h"
#include "sim/flight.h"
#include "sim/random_world.h"
#include "sim/scenario.h"
#include "sim/simulation.h"

namespace oaipp::fuzz {
namespace {

using absl::StatusCode;
using google::protobuf::util::DefaultFieldComparator;
using google::protobuf::util::MessageDifferencer;

constexpr absl::string_view kSource = "fuzz.json";
constexpr std::int64_t kMaxFuzzVoxels = 1 << 17;
constexpr std::int64_t kMaxFuzzVoxelWork = 1 << 21;
constexpr std::int64_t kMaxFuzzCellWork = 1 << 20;
constexpr double kMaxFuzzFalsePositives = 1e4;
// RandomWorld tries up to 200 x 2000 placements per building, each against
// every target, before it gives up: one building with no gap and no start
// clearance, among at most this many targets, keeps that rare and short.
constexpr int kMaxFuzzRandomWorldTargets = 8;

// Field cells of a valid config (FieldGrid caps them at 10'000).
std::int64_t Cells(const api::MissionConfig& c) {
  absl::StatusOr<FieldGrid> grid = c.MakeGrid();
  OAIPP_FUZZ_CHECK(grid.ok(), grid.status().ToString());
  return grid->num_cells();
}

bool Affordable(const v1::Scenario& scenario, const api::MissionConfig& c) {
  const std::int64_t voxels = Esdf::VoxelCount(c.FlightVolume(), c.esdf);
  const auto obstacles = static_cast<std::int64_t>(c.obstacles.size());
  const auto targets = static_cast<std::int64_t>(scenario.targets_size());
  return voxels <= kMaxFuzzVoxels && voxels * (obstacles + 1) <= kMaxFuzzVoxelWork &&
         Cells(c) * (targets + obstacles + 1) <= kMaxFuzzCellWork;
}

// What protobuf prints for a scenario is a scenario file too.
void CheckJsonRoundTrip(const v1::Scenario& scenario) {
  std::string json;
  const auto printed = google::protobuf::util::MessageToJsonString(scenario, &json);
  OAIPP_FUZZ_CHECK(printed.ok(), printed.ToString());
  absl::StatusOr<v1::Scenario> again = sim::ParseScenario(json, kSource);
  OAIPP_FUZZ_CHECK(again.ok(), absl::StrCat("printed scenario refused: ", again.status().ToString(),
                                            "\n", json));
  DefaultFieldComparator comparator;
  comparator.set_treat_nan_as_equal(true);
  MessageDifferencer differencer;
  differencer.set_field_comparator(&comparator);
  // Protobuf's JSON printer leaves out a -0.0 as it leaves out every 0, so
  // it reads back as an unset 0: the same number. Unset fields count as
  // their defaults here.
  differencer.set_message_field_comparison(MessageDifferencer::EQUIVALENT);
  std::string report;
  differencer.ReportDifferencesToString(&report);
  OAIPP_FUZZ_CHECK(differencer.Compare(scenario, *again),
                   absl::StrCat("printed scenario reads back differently: ", report));
}

// One image and a second of hovering at the start, as the client's first
// step does.
void Fly(const sim::Simulation& simulation, const v1::Scenario& scenario) {
  const api::MissionConfig& c = simulation.config();
  const Vec3 start = c.start.position_W;
  (void)simulation.Collides(start);
  const CellLabels truth = simulation.TruthLabels(start);
  OAIPP_FUZZ_CHECK(truth.cells.size() == truth.labels.size(), "truth label count");

  const double rate = simulation.detector().FalsePositiveRate(start.z());
  if (!(rate > kMaxFuzzFalsePositives && rate <= std::numeric_limits<int>::max())) {
    std::mt19937_64 rng(scenario.seed());
    const std::vector<PixelBox> boxes = simulation.Detect(start, rng);
    for (const PixelBox& box : boxes) {
      const absl::Status valid = box.Validate(&simulation.intrinsics());
      OAIPP_FUZZ_CHECK(valid.ok(), absl::StrCat("Detect made a bad box: ", valid.ToString()));
    }
    absl::StatusOr<CellLabels> labels = simulation.Labels(start, boxes);
    CheckError(labels.status(), {StatusCode::kInvalidArgument}, "Simulation::Labels");
  }

  const std::vector<double> zeros(static_cast<std::size_t>(Cells(c)), 0.0);
  OAIPP_FUZZ_CHECK(std::isfinite(simulation.Rse(zeros)), "RSE of a zero map");
  OAIPP_FUZZ_CHECK(std::isfinite(simulation.Rmse(zeros)), "RMSE of a zero map");
  OAIPP_FUZZ_CHECK(simulation.TargetsFound(zeros) == 0, "targets found on a zero map");
  OAIPP_FUZZ_CHECK(static_cast<int>(simulation.TargetIds().size()) == simulation.num_targets(),
                   "target ids");
  OAIPP_FUZZ_CHECK(
      static_cast<int>(simulation.TargetRectangles().size()) == simulation.num_targets(),
      "target rectangles");

  PolynomialTrajectory::SegmentCoefficients hover =
      PolynomialTrajectory::SegmentCoefficients::Zero();
  hover.row(0) = start.transpose();
  absl::StatusOr<PolynomialTrajectory> trajectory =
      PolynomialTrajectory::FromCoefficients({1.0}, {hover});
  OAIPP_FUZZ_CHECK(trajectory.ok(), trajectory.status().ToString());
  sim::Flight flight(simulation, start);
  int steps = 0;
  const absl::StatusOr<double> flown = flight.Fly(*trajectory, 1.0, [&](double) {
    ++steps;
    return true;
  });
  OAIPP_FUZZ_CHECK(flown.ok(), flown.status().ToString());
  OAIPP_FUZZ_CHECK(steps >= 50 && steps <= 52, absl::StrCat(steps, " steps for 1 s"));
  OAIPP_FUZZ_CHECK(flight.path_length_m() == 0.0, "hovering flew somewhere");
}

void RandomWorld(const v1::Scenario& scenario) {
  if (scenario.targets_size() > kMaxFuzzRandomWorldTargets) return;
  absl::StatusOr<v1::Scenario> world =
      sim::RandomWorld(scenario, {.kind = sim::BuildingKind::kLowRise,
                                  .count = 1,
                                  .seed = scenario.seed(),
                                  .gap_m = 0.0,
                                  .start_clearance_m = 0.0});
  CheckError(world.status(),
             {StatusCode::kInvalidArgument, StatusCode::kFailedPrecondition,
              StatusCode::kResourceExhausted},
             "RandomWorld");
  if (!world.ok()) return;
  absl::StatusOr<api::MissionConfig> config = api::MissionSpecToConfig(world->mission());
  OAIPP_FUZZ_CHECK(config.ok(), absl::StrCat("RandomWorld made a mission that does not convert: ",
                                             config.status().ToString()));
}

void Run(absl::string_view json) {
  absl::StatusOr<v1::Scenario> scenario = sim::ParseScenario(json, kSource);
  CheckError(scenario.status(), {StatusCode::kInvalidArgument}, "ParseScenario");
  if (!scenario.ok()) {
    OAIPP_FUZZ_CHECK(absl::StartsWith(scenario.status().message(), absl::StrCat(kSource, ":")),
                     scenario.status().ToString());
    return;
  }
  CheckJsonRoundTrip(*scenario);

  absl::StatusOr<api::MissionConfig> config = api::MissionSpecToConfig(scenario->mission());
  if (!config.ok() || !Affordable(*scenario, *config)) return;
  absl::StatusOr<sim::Simulation> simulation = sim::Simulation::Create(*scenario);
  CheckError(simulation.status(), {StatusCode::kInvalidArgument, StatusCode::kResourceExhausted},
             "Simulation::Create");
  if (!simulation.ok()) return;
  Fly(*simulation, *scenario);
  RandomWorld(*scenario);
}

}  // namespace
}  // namespace oaipp::fuzz

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  // Protobuf's JSON parser logs some refusals; the status is what counts.
  google::protobuf::SetLogHandler(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  oaipp::fuzz::Run(absl::string_view(reinterpret_cast<const char*>(data), size));
  return 0;
}
