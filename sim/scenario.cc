#include "sim/scenario.h"

#include <fstream>
#include <sstream>

#include "absl/strings/str_cat.h"
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
