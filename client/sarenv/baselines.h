// The SAREnv benchmark's five baseline planners, as paths for n drones
// within a total flight budget over a SearchArea:
//   Spiral      an Archimedean spiral out from the centre, one path cut into
//               n consecutive pieces;
//   Concentric  circles around the centre joined by short transitions, one
//               path cut into n pieces;
//   Pizza       n equal sectors, each drone zigzagging arcs outwards in its
//               own;
//   Greedy      steps between neighbouring cells (8-connected), always to
//               the one that sees the most probability not yet seen, and
//               to a random one when none sees anything new;
//   RandomWalk  Greedy on a map of zeros: every step a random neighbour.
// Every path is cut to budget / n. Greedy and RandomWalk draw from
// std::mt19937_64(seed); the others do not use the seed.
//
//   absl::StatusOr<std::vector<Polyline>> paths =
//       PlanBaseline(Baseline::kSpiral, area, /*n_drones=*/2, /*budget_m=*/100000, /*seed=*/1);
//   absl::StatusOr<PathMetrics> m = EvaluatePaths(area, *paths, victims);
#pragma once

#include <cstdint>
#include <vector>
#include "absl/strings/string_view.h"

#include "absl/status/statusor.h"
#include "client/sarenv/dataset.h"
#include "client/sarenv/metrics.h"

namespace oaipp::sarenv {

enum class Baseline { kSpiral, kConcentric, kPizza, kGreedy, kRandomWalk };

// "Spiral", "Concentric", "Pizza", "Greedy", "RandomWalk": the names in the
// benchmark's result tables.
[[nodiscard]] absl::string_view BaselineName(Baseline baseline);

// A name as above, in any letter case.
[[nodiscard]] absl::StatusOr<Baseline> ParseBaseline(absl::string_view name);

// Whether the planner draws random numbers (its published numbers then
// cannot be reproduced).
[[nodiscard]] bool IsRandomized(Baseline baseline);

struct BaselineOptions {
  double altitude_m = 80.0;
  double fov_deg = 45.0;
  // Share of a sweep's width that neighbouring sweeps overlap; the spacing
  // of spiral loops, circles and arcs is 2 altitude tan(fov / 2) (1 - overlap).
  double overlap = 0.0;
  double point_spacing_m = 10.0;  // between the points of spirals and arcs
  double transition_m = 50.0;     // Concentric: the arc left open to move out
  double border_gap_m = 15.0;     // Pizza: kept from the sector's edges
  // Greedy: among moves of equal positive gain, false takes the first in
  // the fixed order (row - 1, col - 1), (row - 1, col), (row - 1, col + 1),
  // (row, col - 1), (row, col + 1), (row + 1, col - 1), ... as the
  // benchmark's code does (its published Greedy numbers come from that);
  // true draws one at random. Either way, when no move gains anything
  // the step goes to a random valid neighbour.
  bool greedy_random_ties = false;
};

// Paths for n_drones (>= 1) within a total budget_m (> 0; each path is cut
// to budget_m / n_drones). Pizza returns one path per drone, the others
// n_drones paths of which some may be empty. InvalidArgument for a bad
// count or budget.
[[nodiscard]] absl::StatusOr<std::vector<Polyline>> PlanBaseline(
    Baseline baseline, const SearchArea& area, int n_drones, double budget_m, uint64_t seed,
    const BaselineOptions& options = {});

// The seeds oaipp-sarenv and E8 draw with (std::mt19937_64): dataset N's
// victims use DatasetSeed(seed, N) = seed * 1000000 + N * 1000, and a
// randomized baseline's plan for n drones on it
// DatasetSeed + 10 n + 1 (Greedy) or + 2 (RandomWalk).
[[nodiscard]] uint64_t DatasetSeed(uint64_t seed, int dataset);
[[nodiscard]] uint64_t BaselineSeed(uint64_t dataset_seed, Baseline baseline, int n_drones);

}  // namespace oaipp::sarenv
