// A search team's map files, read through GDAL (GeoJSON, KML, GeoPackage or
// an ESRI Shapefile) into the mission's messages: the search area, the
// fence, no-fly zones and OpenStreetMap building footprints. Every ring is
// given as WGS84 latitude/longitude (Ring.lat_lon_deg), which the server
// places on the mission's local frame, so the mission needs a geo_origin.
// A file in another CRS is transformed to WGS84; a GeoPackage or Shapefile
// layer without a CRS is an error (only GeoJSON and KML are WGS84 without
// saying so). Tables without geometry (a GeoPackage's layer_styles) are
// not read. docs/search-files.md says what is read, with which property
// names and defaults.
//
// What cannot be used is left out and said, one line per thing, in
// `dropped` ("search_files.buildings: feature 7 (way/4711): its outer ring
// crosses itself; dropped"); a building that takes the default height is
// listed there too. Input that leaves nothing sensible to do (a missing or
// unreadable file, an area with no usable polygon, a fence that is not one
// simple polygon, a no-fly zone that cannot be read) is an error whose
// message starts with `field`. Features are read in file order, so the
// same file gives the same messages and ids.
//
//   std::vector<std::string> dropped;
//   absl::StatusOr<std::vector<v1::AreaPolygon>> area =
//       geo_import::ReadSearchArea("maps/area.kml", "search_files.area", dropped);
//   if (!area.ok()) return area.status();
//   for (const std::string& line : dropped) std::cerr << line << "\n";
#pragma once

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "client/geo_import/osm_height.h"
#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::client::geo_import {

// The API's bound on a prism footprint's and a fence polygon's vertices
// (Prism.footprint, Fence.polygon).
inline constexpr int kMaxRingVertices = 256;

// A no-fly zone's floor and ceiling, metres above the field (world z), when
// the feature has no floor_m or ceiling_m property.
inline constexpr double kDefaultZoneFloorM = 0.0;
inline constexpr double kDefaultZoneCeilingM = 1000.0;

// Every usable Polygon and MultiPolygon part, holes kept, one AreaPolygon
// each. Dropped: polygons that fail the checks (a ring not closed, fewer
// than 3 distinct vertices, no area, a ring that crosses or touches itself,
// a hole outside its ring or meeting it or another hole along an edge, a
// vertex outside WGS84's ranges), features that are not polygons.
// InvalidArgument when none is left.
[[nodiscard]] absl::StatusOr<std::vector<v1::AreaPolygon>> ReadSearchArea(
    const std::string& path, absl::string_view field, std::vector<std::string>& dropped);

// The file's one polygon, as Fence.polygon. Features that are not polygons
// are dropped; InvalidArgument when the file has no polygon or more than
// one, or when the one has holes, more than kMaxRingVertices vertices or
// fails the checks: a fence is never guessed.
[[nodiscard]] absl::StatusOr<v1::Fence> ReadFence(const std::string& path, absl::string_view field,
                                                  std::vector<std::string>& dropped);

// One zone per polygon (a prism from floor_m to ceiling_m; holes are
// closed, and listed) and per Point with a radius_m property (a cylinder
// between the same heights, its centre at `origin_altitude_m` plus the
// middle height, so that the server puts it at that world z). Ids
// "zone-<n>", n the feature's place in the file, "zone-<n>-<k>" for the
// k-th polygon of a multi-part feature. Nothing in this file is dropped:
// closed airspace that cannot be read, a bad floor_m, ceiling_m or
// radius_m, or a feature that is not a polygon or a point with a radius is
// InvalidArgument naming the feature.
[[nodiscard]] absl::StatusOr<std::vector<v1::Obstacle>> ReadNoFlyZones(
    const std::string& path, absl::string_view field, double origin_altitude_m,
    std::vector<std::string>& dropped);

// One prism obstacle per polygon of every feature tagged building (any
// value but "no"), from 0 m to OsmBuildingHeight's height; ids
// "building-<n>" and "building-<n>-<k>" as for zones. Holes (courtyards) are
// closed and listed. Dropped: footprints that fail the checks or have more
// than kMaxRingVertices vertices, and building features that are not
// polygons; features without a building tag are skipped and counted in one
// line. Listed: each building that takes the default height.
[[nodiscard]] absl::StatusOr<std::vector<v1::Obstacle>> ReadBuildings(
    const std::string& path, absl::string_view field, const BuildingHeightRules& rules,
    std::vector<std::string>& dropped);

}  // namespace oaipp::client::geo_import
