// A scenario's map files (Scenario.search_files): read when the client
// loads the scenario, through client/geo_import/, into the mission's
// search_areas, fence, no_fly_zones and obstacles, so that the server gets
// rings and nothing else needs the files.
//
//   OAIPP_ASSIGN_OR_RETURN(v1::Scenario s, sim::LoadScenarioFile(path));
//   std::vector<std::string> dropped;
//   OAIPP_RETURN_IF_ERROR(ReadSearchFiles(s, path, dropped));
//   for (const std::string& line : dropped) std::cerr << line << "\n";
#pragma once

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "sim/scenario.h"

namespace oaipp::client::cli {

// Fills the mission from scenario.search_files (paths relative to
// `scenario_path`'s folder, or absolute) and clears it; does nothing
// without one. `dropped` gets a line for everything read but left out, or
// given a default (geo_import.h). Errors start with the scenario's path and
// name the field ("search_files.area: ..."): InvalidArgument when the
// mission has no geo_origin, when it sets search_areas beside
// search_files.area or a fence beside search_files.fence, when an imported
// id is already an obstacle's or a zone's, when the buildings and the
// mission's own obstacles are more than api::kMaxObstacles (1000), when
// metres_per_level or default_building_height_m is not > 0 and finite, or
// when a file holds nothing usable; NotFound when a file is missing. The
// rings themselves are checked again by the server.
[[nodiscard]] absl::Status ReadSearchFiles(v1::Scenario& scenario, const std::string& scenario_path,
                                           std::vector<std::string>& dropped);

}  // namespace oaipp::client::cli
