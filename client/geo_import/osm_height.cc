#include "client/geo_import/osm_height.h"

#include <cmath>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "client/geo_import/internal/vector_file.h"

namespace oaipp::client::geo_import {

std::optional<double> ParseOsmMetres(absl::string_view text) {
  text = absl::StripAsciiWhitespace(text);
  if (absl::ConsumeSuffix(&text, "m")) text = absl::StripTrailingAsciiWhitespace(text);
  double value = 0.0;
  // SimpleAtod also takes "inf", "nan" and hexadecimal; the range check
  // below refuses the first two, and OSM never writes the third.
  if (text.empty() || !absl::SimpleAtod(text, &value)) return std::nullopt;
  if (!(value > 0.0 && value <= 1000.0)) return std::nullopt;
  return value;
}

BuildingHeight OsmBuildingHeight(const std::optional<std::string>& height,
                                 const std::optional<std::string>& levels,
                                 const BuildingHeightRules& rules) {
  std::string note;
  if (height.has_value()) {
    if (const std::optional<double> h = ParseOsmMetres(*height); h.has_value()) {
      return {.height_m = *h, .source = HeightSource::kHeightTag, .note = ""};
    }
    note = absl::StrCat("height '", internal::Bounded(*height), "' is not metres in (0, 1000]");
  }
  if (levels.has_value()) {
    double n = 0.0;
    if (absl::SimpleAtod(absl::StripAsciiWhitespace(*levels), &n) && n > 0.0 && n <= 300.0) {
      return {
          .height_m = n * rules.metres_per_level, .source = HeightSource::kLevelsTag, .note = note};
    }
    absl::StrAppend(&note, note.empty() ? "" : "; ", "building:levels '",
                    internal::Bounded(*levels), "' is not a number of storeys in (0, 300]");
  }
  if (note.empty()) note = "no height or building:levels tag";
  return {.height_m = rules.default_height_m, .source = HeightSource::kDefault, .note = note};
}

}  // namespace oaipp::client::geo_import
