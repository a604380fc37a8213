#include "sim/scenario.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include "absl/strings/str_cat.h"
#include "api/geodetic.h"
#include "google/protobuf/util/json_util.h"
#include "nlohmann/json.hpp"

namespace oaipp::sim {

absl::StatusOr<v1::Scenario> ParseScenario(absl::string_view json, absl::string_view source) {
  // nlohmann's parser reports where the JSON breaks; protobuf's reports
  // which field does not fit the schema. Syntax first, then the schema.
  try {
    [[maybe_unused]] const nlohmann::json parsed = nlohmann::json::parse(json.begin(), json.end());
  } catch (const nlohmann::json::parse_error& e) {
    const std::size_t offset = std::min(e.byte, json.size());
    int line = 1, column = 1;
    for (std::size_t i = 0; i + 1 < offset; ++i) {
      if (json[i] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
    std::string what = e.what();
    if (const auto pos = what.find("syntax error while parsing "); pos != std::string::npos) {
      what = what.substr(pos);
    }
    return absl::InvalidArgumentError(absl::StrCat(source, ":", line, ":", column, ": ", what));
  } catch (const nlohmann::json::out_of_range&) {
    // A number beyond a double's range (1e400): nlohmann gives no place.
    return absl::InvalidArgumentError(
        absl::StrCat(source, ": a number is out of range (beyond +-1.8e308)"));
  }
  v1::Scenario scenario;
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  const auto status =
      google::protobuf::util::JsonStringToMessage(std::string(json), &scenario, options);
  if (!status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(source, ": ", status.message().as_string()));
  }
  if (scenario.has_path_budget_m() &&
      !(scenario.path_budget_m() > 0 && std::isfinite(scenario.path_budget_m()))) {
    return absl::InvalidArgumentError(
        absl::StrCat(source, ": path_budget_m: must be > 0 and finite"));
  }
  // Targets given by latitude/longitude become local rectangles here, so
  // that everything after sees local metres only (as the server does).
  for (int i = 0; i < scenario.targets_size(); ++i) {
    v1::Target& t = *scenario.mutable_targets(i);
    if (!t.has_centre_geo()) continue;
    const std::string field = absl::StrCat(source, ": targets[", i, "].centre_geo");
    if (!scenario.mission().has_geo_origin()) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": mission.geo_origin is not set, so give the x/y bounds"));
    }
    if (t.x_min_m() != 0 || t.x_max_m() != 0 || t.y_min_m() != 0 || t.y_max_m() != 0) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": give the bounds or centre_geo, not both"));
    }
    absl::StatusOr<api::GeoPoint> origin =
        api::GeoPointFromProto(scenario.mission().geo_origin(), "mission.geo_origin");
    if (!origin.ok())
      return absl::InvalidArgumentError(absl::StrCat(source, ": ", origin.status().message()));
    absl::StatusOr<api::GeoPoint> centre = api::GeoPointFromProto(t.centre_geo(), field);
    if (!centre.ok()) return centre.status();
    const Vec3 c = api::GeoFrame::FromOrigin(*origin)->ToLocal(*centre);
    const double sx = t.has_size_x_m() ? t.size_x_m() : 0.75;
    const double sy = t.has_size_y_m() ? t.size_y_m() : 2.0;
    if (!(sx > 0 && sy > 0 && sx < 1e4 && sy < 1e4)) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": size_x_m and size_y_m must be in (0, 1e4)"));
    }
    t.set_x_min_m(c.x() - 0.5 * sx);
    t.set_x_max_m(c.x() + 0.5 * sx);
    t.set_y_min_m(c.y() - 0.5 * sy);
    t.set_y_max_m(c.y() + 0.5 * sy);
    t.clear_centre_geo();
    t.clear_size_x_m();
    t.clear_size_y_m();
  }
  return scenario;
}

absl::StatusOr<v1::Scenario> LoadScenarioFile(const std::string& path) {
  std::ifstream file(path);
  if (!file) return absl::NotFoundError(absl::StrCat(path, ": cannot open"));
  std::stringstream text;
  text << file.rdbuf();
  return ParseScenario(text.str(), path);
}

}  // namespace oaipp::sim
