// A building's height from its OpenStreetMap tags (wiki: Key:height,
// Key:building:levels): `height` in metres, else `building:levels` storeys
// of a given height each, else a default, with the reason it was taken.
//
//   BuildingHeight h = OsmBuildingHeight("12 m", std::nullopt, {});
//   // h.height_m == 12, h.source == HeightSource::kHeightTag
#pragma once

#include <optional>
#include <string>

#include "absl/strings/string_view.h"

namespace oaipp::client::geo_import {

// Metres of one storey and the height of a building with no usable tag.
struct BuildingHeightRules {
  double metres_per_level = 3.0;   // > 0
  double default_height_m = 10.0;  // > 0
};

enum class HeightSource { kHeightTag, kLevelsTag, kDefault };

struct BuildingHeight {
  double height_m = 0.0;
  HeightSource source = HeightSource::kDefault;
  // Why a tag that was there could not be used, or, with kDefault, why the
  // default was taken ("no height or building:levels tag"); empty when the
  // height tag was used. Tag values in it are bounded (40 bytes).
  std::string note;
};

// A length in metres as OSM writes it: a number, optionally followed by
// "m" (with or without a space): "12", "12.5", "12 m", "12m". nullopt for
// anything else (feet such as 40', other units, text) and for values that
// are not in (0, 1000].
[[nodiscard]] std::optional<double> ParseOsmMetres(absl::string_view text);

// From the tags' values (nullopt: the tag is absent). building:levels is a
// positive number of storeys, at most 300.
[[nodiscard]] BuildingHeight OsmBuildingHeight(const std::optional<std::string>& height,
                                               const std::optional<std::string>& levels,
                                               const BuildingHeightRules& rules);

}  // namespace oaipp::client::geo_import
