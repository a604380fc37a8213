#include "client/cli/search_files.h"

#include <cmath>
#include <filesystem>
#include <utility>

#include "absl/container/flat_hash_set.h"
#include "absl/strings/str_cat.h"
#include "api/limits.h"
#include "client/geo_import/geo_import.h"

namespace oaipp::client::cli {
namespace {

std::string Resolve(const std::string& file, const std::string& scenario_path) {
  std::filesystem::path path(file);
  if (path.is_relative()) path = std::filesystem::path(scenario_path).parent_path() / path;
  return path.string();
}

// A status from geo_import with the scenario's path in front.
absl::Status InScenario(const absl::Status& status, const std::string& scenario_path) {
  return absl::Status(status.code(), absl::StrCat(scenario_path, ": ", status.message()));
}

absl::Status PositiveOption(bool has, double value, const char* name, double& out) {
  if (!has) return absl::OkStatus();
  if (!(value > 0.0) || !std::isfinite(value)) {
    return absl::InvalidArgumentError(
        absl::StrCat("search_files.", name, ": must be > 0 and finite, got ", value));
  }
  out = value;
  return absl::OkStatus();
}

// Appends `imported` to `list`; InvalidArgument naming `field` when an id is
// already taken by an obstacle or a zone.
absl::Status Append(std::vector<v1::Obstacle> imported,
                    google::protobuf::RepeatedPtrField<v1::Obstacle>& list,
                    absl::flat_hash_set<std::string>& ids, const char* field) {
  for (v1::Obstacle& o : imported) {
    if (!ids.insert(o.id()).second) {
      return absl::InvalidArgumentError(absl::StrCat(
          field, ": id ", o.id(), " is already an obstacle's or a zone's in the mission"));
    }
    *list.Add() = std::move(o);
  }
  return absl::OkStatus();
}

absl::Status Read(v1::Scenario& scenario, const std::string& scenario_path,
                  std::vector<std::string>& dropped) {
  const v1::SearchFiles& files = scenario.search_files();
  v1::MissionSpec& mission = *scenario.mutable_mission();
  if (!mission.has_geo_origin()) {
    return absl::InvalidArgumentError(
        "search_files: mission.geo_origin is not set; map files are placed through it");
  }
  geo_import::BuildingHeightRules rules;
  if (absl::Status s = PositiveOption(files.has_metres_per_level(), files.metres_per_level(),
                                      "metres_per_level", rules.metres_per_level);
      !s.ok()) {
    return s;
  }
  if (absl::Status s =
          PositiveOption(files.has_default_building_height_m(), files.default_building_height_m(),
                         "default_building_height_m", rules.default_height_m);
      !s.ok()) {
    return s;
  }
  if (!files.area().empty()) {
    if (mission.search_areas_size() > 0) {
      return absl::InvalidArgumentError("search_files.area: not with mission.search_areas");
    }
    absl::StatusOr<std::vector<v1::AreaPolygon>> area = geo_import::ReadSearchArea(
        Resolve(files.area(), scenario_path), "search_files.area", dropped);
    if (!area.ok()) return area.status();
    for (v1::AreaPolygon& p : *area) *mission.add_search_areas() = std::move(p);
  }
  if (!files.fence().empty()) {
    if (mission.has_fence()) {
      return absl::InvalidArgumentError("search_files.fence: not with mission.fence");
    }
    absl::StatusOr<v1::Fence> fence =
        geo_import::ReadFence(Resolve(files.fence(), scenario_path), "search_files.fence", dropped);
    if (!fence.ok()) return fence.status();
    *mission.mutable_fence() = *std::move(fence);
  }
  // Obstacles and zones share one id space here so that the messages say
  // which file a clash came from.
  absl::flat_hash_set<std::string> ids;
  for (const v1::Obstacle& o : mission.obstacles()) ids.insert(o.id());
  for (const v1::Obstacle& o : mission.no_fly_zones()) ids.insert(o.id());
  if (!files.no_fly_zones().empty()) {
    absl::StatusOr<std::vector<v1::Obstacle>> zones = geo_import::ReadNoFlyZones(
        Resolve(files.no_fly_zones(), scenario_path), "search_files.no_fly_zones",
        mission.geo_origin().altitude_m(), dropped);
    if (!zones.ok()) return zones.status();
    if (absl::Status s = Append(*std::move(zones), *mission.mutable_no_fly_zones(), ids,
                                "search_files.no_fly_zones");
        !s.ok()) {
      return s;
    }
  }
  if (!files.buildings().empty()) {
    absl::StatusOr<std::vector<v1::Obstacle>> buildings = geo_import::ReadBuildings(
        Resolve(files.buildings(), scenario_path), "search_files.buildings", rules, dropped);
    if (!buildings.ok()) return buildings.status();
    // The server would refuse the whole spec (spec.obstacles); said here,
    // the message names the file that overflowed.
    const std::size_t total =
        static_cast<std::size_t>(mission.obstacles_size()) + buildings->size();
    if (total > static_cast<std::size_t>(api::kMaxObstacles)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "search_files.buildings: ", buildings->size(), " buildings and the mission's ",
          mission.obstacles_size(), " obstacles make ", total, " obstacles; a mission has at most ",
          api::kMaxObstacles));
    }
    if (absl::Status s = Append(*std::move(buildings), *mission.mutable_obstacles(), ids,
                                "search_files.buildings");
        !s.ok()) {
      return s;
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status ReadSearchFiles(v1::Scenario& scenario, const std::string& scenario_path,
                             std::vector<std::string>& dropped) {
  if (!scenario.has_search_files()) return absl::OkStatus();
  if (absl::Status s = Read(scenario, scenario_path, dropped); !s.ok()) {
    return InScenario(s, scenario_path);
  }
  scenario.clear_search_files();
  return absl::OkStatus();
}

}  // namespace oaipp::client::cli
