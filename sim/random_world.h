// E3's random worlds (docs/method.md §10): n buildings of one kind placed at
// random over a scenario's field, from a seed.
//
//   OAIPP_ASSIGN_OR_RETURN(v1::Scenario s,
//       RandomWorld(e1, {.kind = BuildingKind::kHighRise, .count = 10, .seed = 7}));
#pragma once

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"
#include "oaipp/v1/scenario.pb.h"

namespace oaipp::sim {

enum class BuildingKind {
  kLowRise,   // 4 x 4 x 13 m
  kHighRise,  // 4 x 4 x 26 m, as tall as the flight volume
};

struct RandomWorldOptions {
  BuildingKind kind = BuildingKind::kLowRise;
  int count = 5;  // buildings. Valid: 0 .. 40.
  std::uint64_t seed = 1;
  // Free space kept between buildings, metres, so that the field does not
  // turn into a maze; also kept around targets. Valid: >= 0.
  double gap_m = 1.0;
  // No building within this horizontal distance of the start, metres.
  double start_clearance_m = 4.0;
};

// "low-rise" or "high-rise".
[[nodiscard]] std::string BuildingKindName(BuildingKind kind);

// `base` with its obstacles replaced by options.count axis-aligned buildings
// with centres drawn uniformly (std::mt19937_64 seeded with options.seed)
// such that each lies inside the mission's field, none overlaps
// another or a target (both grown by gap_m) or comes within
// start_clearance_m of the start. The same base and options give the same
// world. InvalidArgument for bad options; FailedPrecondition when the
// buildings do not fit (placement starts over up to 200 times).
[[nodiscard]] absl::StatusOr<v1::Scenario> RandomWorld(const v1::Scenario& base,
                                                       const RandomWorldOptions& options);

}  // namespace oaipp::sim
