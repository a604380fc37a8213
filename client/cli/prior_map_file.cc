#include "client/cli/prior_map_file.h"

#include <cmath>
#include <filesystem>
#include <utility>

#include "absl/strings/str_cat.h"
#include "api/spec.h"
#include "client/sarenv/npy.h"
#include "core/common/status_macros.h"

namespace oaipp::client::cli {

absl::Status ReadPriorMapFile(v1::Scenario& scenario, const std::string& scenario_path) {
  if (!scenario.has_prior_map_file()) return absl::OkStatus();
  const v1::PriorMapFile& file = scenario.prior_map_file();
  v1::GpSpec& gp = *scenario.mutable_mission()->mutable_gp();
  if (gp.has_prior_map() || gp.has_prior_mean()) {
    return absl::InvalidArgumentError(
        absl::StrCat(scenario_path, ": prior_map_file: not with mission.gp.",
                     gp.has_prior_map() ? "prior_map" : "prior_mean"));
  }
  const double scale = file.has_scale() ? file.scale() : 1.0;
  if (!(scale > 0.0) || !std::isfinite(scale)) {
    return absl::InvalidArgumentError(
        absl::StrCat(scenario_path, ": prior_map_file.scale: must be > 0 and finite, got ", scale));
  }
  std::filesystem::path path(file.path());
  if (path.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(scenario_path, ": prior_map_file.path: must name a .npy file"));
  }
  if (path.is_relative()) path = std::filesystem::path(scenario_path).parent_path() / path;
  // The field's cells, from the mission as the server will read it.
  absl::StatusOr<api::MissionConfig> config = api::MissionSpecToConfig(scenario.mission());
  if (!config.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(scenario_path, ": mission: ", config.status().message()));
  }
  OAIPP_ASSIGN_OR_RETURN(const FieldGrid grid, config->MakeGrid());
  OAIPP_ASSIGN_OR_RETURN(const sarenv::Grid2D map, sarenv::ReadNpy(path.string()));
  if (map.rows != grid.ny() || map.cols != grid.nx()) {
    return absl::InvalidArgumentError(absl::StrCat(
        scenario_path, ": prior_map_file.path: ", path.string(), " holds ", map.rows, " x ",
        map.cols, " values; the field has ", grid.ny(), " rows x ", grid.nx(), " columns"));
  }
  v1::PriorMap& prior = *gp.mutable_prior_map();
  prior.set_units(file.units());
  prior.mutable_values()->Reserve(grid.num_cells());
  for (int row = 0; row < grid.ny(); ++row) {
    const int from = file.first_row_north() ? grid.ny() - 1 - row : row;
    for (int col = 0; col < grid.nx(); ++col) prior.add_values(scale * map.At(from, col));
  }
  scenario.clear_prior_map_file();
  return absl::OkStatus();
}

}  // namespace oaipp::client::cli
