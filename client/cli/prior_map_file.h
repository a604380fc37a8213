// A scenario's prior map on disk (Scenario.prior_map_file): read when the
// client loads the scenario, into mission.gp.prior_map, so that the server
// gets the values and nothing else needs the file.
//
//   OAIPP_ASSIGN_OR_RETURN(v1::Scenario s, sim::LoadScenarioFile(path));
//   OAIPP_RETURN_IF_ERROR(ReadPriorMapFile(s, path));
#pragma once

#include <string>

#include "absl/status/status.h"
#include "sim/scenario.h"

namespace oaipp::client::cli {

// Fills scenario.mission.gp.prior_map from scenario.prior_map_file (a path
// relative to `scenario_path`'s folder, or absolute) and clears the latter;
// does nothing without one. InvalidArgument naming the field when the file
// is not a 2-D float64 .npy of the field's ny x nx cells, the scale is not
// positive and finite, or the mission sets gp.prior_map or gp.prior_mean
// too; NotFound when the file cannot be opened. The values themselves are
// checked by the server (GpSpec.prior_map).
[[nodiscard]] absl::Status ReadPriorMapFile(v1::Scenario& scenario,
                                            const std::string& scenario_path);

}  // namespace oaipp::client::cli
