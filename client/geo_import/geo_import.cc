#include "client/geo_import/geo_import.h"

#include <cmath>
#include <optional>
#include <utility>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "client/geo_import/internal/vector_file.h"

namespace oaipp::client::geo_import {
namespace {

using internal::Feature;
using internal::LatLonPolygon;
using internal::LatLonRing;
using internal::VectorFile;

void ToRing(const LatLonRing& ring, v1::Ring& out) {
  out.mutable_lat_lon_deg()->Reserve(2 * static_cast<int>(ring.size()));
  for (const internal::LatLon& v : ring) {
    out.add_lat_lon_deg(v.lat_deg);
    out.add_lat_lon_deg(v.lon_deg);
  }
}

// "zone-3", or "zone-3-2" for the second polygon of feature 3's several
// (the second in the geometry, whether or not the first was usable).
std::string PartId(absl::string_view prefix, const Feature& f, const LatLonPolygon& p) {
  if (f.polygons_in_geometry <= 1) return absl::StrCat(prefix, "-", f.number);
  return absl::StrCat(prefix, "-", f.number, "-", p.part);
}

// "polygon 2 of 3: " when the feature has several, else "".
std::string PartName(const Feature& f, const LatLonPolygon& p) {
  if (f.polygons_in_geometry <= 1) return "";
  return absl::StrCat("polygon ", p.part, " of ", f.polygons_in_geometry, ": ");
}

// "1 hole", "2 holes".
std::string Count(std::size_t n, absl::string_view one, absl::string_view many) {
  return absl::StrCat(n, " ", n == 1 ? one : many);
}

void DropRejected(absl::string_view field, const Feature& f, std::vector<std::string>& dropped) {
  for (const std::string& why : f.rejected) {
    dropped.push_back(absl::StrCat(field, ": ", f.label, ": ", why, "; dropped"));
  }
  if (f.no_geometry)
    dropped.push_back(absl::StrCat(field, ": ", f.label, ": no geometry; dropped"));
}

// A number property of a zone: `fallback` when absent; InvalidArgument
// when present and not a finite number in [min, max].
absl::StatusOr<double> ZoneNumber(absl::string_view field, const Feature& f, absl::string_view name,
                                  double fallback, double min, double max) {
  const std::optional<std::string> text = f.Property(name);
  if (!text.has_value()) return fallback;
  double value = 0.0;
  if (!absl::SimpleAtod(*text, &value) || !(value >= min && value <= max)) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": ", f.label, ": ", name, " '",
                                                   internal::Bounded(*text),
                                                   "' is not a number in [", min, ", ", max, "]"));
  }
  return value;
}

}  // namespace

absl::StatusOr<std::vector<v1::AreaPolygon>> ReadSearchArea(const std::string& path,
                                                            absl::string_view field,
                                                            std::vector<std::string>& dropped) {
  absl::StatusOr<VectorFile> file = VectorFile::Open(path, field);
  if (!file.ok()) return file.status();
  std::vector<v1::AreaPolygon> area;
  const std::size_t dropped_before = dropped.size();
  const absl::Status read = file->ForEach([&](const Feature& f) {
    DropRejected(field, f, dropped);
    if (f.point.has_value()) {
      dropped.push_back(absl::StrCat(field, ": ", f.label, ": a Point is not an area; dropped"));
    }
    for (const LatLonPolygon& p : f.polygons) {
      v1::AreaPolygon& polygon = area.emplace_back();
      ToRing(p.outer, *polygon.mutable_outer());
      for (const LatLonRing& hole : p.holes) ToRing(hole, *polygon.add_holes());
    }
    return absl::OkStatus();
  });
  if (!read.ok()) return read;
  if (area.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        field, ": ", internal::Bounded(path, 300), " has no usable polygon",
        dropped.size() > dropped_before ? absl::StrCat(" (", dropped[dropped_before], ")") : ""));
  }
  return area;
}

absl::StatusOr<v1::Fence> ReadFence(const std::string& path, absl::string_view field,
                                    std::vector<std::string>& dropped) {
  absl::StatusOr<VectorFile> file = VectorFile::Open(path, field);
  if (!file.ok()) return file.status();
  std::optional<LatLonPolygon> polygon;
  int polygons = 0;
  const absl::Status read = file->ForEach([&](const Feature& f) -> absl::Status {
    polygons += f.polygons_in_geometry;
    if (polygons > 1) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": ", f.label, ": a second polygon; a fence is one polygon"));
    }
    if (f.polygons_in_geometry == 1 && f.polygons.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": ", f.label, ": ", f.rejected.front()));
    }
    DropRejected(field, f, dropped);
    if (f.point.has_value()) {
      dropped.push_back(absl::StrCat(field, ": ", f.label, ": a Point is not a fence; dropped"));
    }
    if (!f.polygons.empty()) polygon = f.polygons.front();
    return absl::OkStatus();
  });
  if (!read.ok()) return read;
  if (!polygon.has_value()) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": ", internal::Bounded(path, 300), " has no polygon"));
  }
  if (!polygon->holes.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": the polygon has ", Count(polygon->holes.size(), "hole", "holes"),
                     "; a fence is one ring (give holes as no_fly_zones)"));
  }
  if (polygon->outer.size() > kMaxRingVertices) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": the polygon has ",
                                                   polygon->outer.size(), " vertices, more than ",
                                                   kMaxRingVertices));
  }
  v1::Fence fence;
  ToRing(polygon->outer, *fence.mutable_polygon());
  return fence;
}

absl::StatusOr<std::vector<v1::Obstacle>> ReadNoFlyZones(const std::string& path,
                                                         absl::string_view field,
                                                         double origin_altitude_m,
                                                         std::vector<std::string>& dropped) {
  absl::StatusOr<VectorFile> file = VectorFile::Open(path, field);
  if (!file.ok()) return file.status();
  std::vector<v1::Obstacle> zones;
  const absl::Status read = file->ForEach([&](const Feature& f) -> absl::Status {
    // Closed airspace is never dropped: anything this cannot read is an
    // error for the team to fix.
    if (!f.rejected.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": ", f.label, ": ", f.rejected.front()));
    }
    if (f.no_geometry) {
      return absl::InvalidArgumentError(absl::StrCat(field, ": ", f.label, ": no geometry"));
    }
    constexpr double kMaxHeightM = 100000.0;
    absl::StatusOr<double> floor_m =
        ZoneNumber(field, f, "floor_m", kDefaultZoneFloorM, 0.0, kMaxHeightM);
    if (!floor_m.ok()) return floor_m.status();
    absl::StatusOr<double> ceiling_m =
        ZoneNumber(field, f, "ceiling_m", kDefaultZoneCeilingM, 0.0, kMaxHeightM);
    if (!ceiling_m.ok()) return ceiling_m.status();
    if (!(*ceiling_m > *floor_m)) {
      return absl::InvalidArgumentError(absl::StrCat(
          field, ": ", f.label, ": ceiling_m ", *ceiling_m, " is not above floor_m ", *floor_m));
    }
    if (f.point.has_value()) {
      if (!f.Property("radius_m").has_value()) {
        return absl::InvalidArgumentError(
            absl::StrCat(field, ": ", f.label, ": a Point needs a radius_m property to be a zone"));
      }
      absl::StatusOr<double> radius_m = ZoneNumber(field, f, "radius_m", 0.0, 0.0, kMaxHeightM);
      if (!radius_m.ok()) return radius_m.status();
      if (!(*radius_m > 0.0)) {
        return absl::InvalidArgumentError(
            absl::StrCat(field, ": ", f.label, ": radius_m must be > 0"));
      }
      v1::Obstacle& zone = zones.emplace_back();
      zone.set_id(absl::StrCat("zone-", f.number));
      v1::Cylinder& cylinder = *zone.mutable_cylinder();
      cylinder.mutable_centre_geo()->set_latitude_deg(f.point->lat_deg);
      cylinder.mutable_centre_geo()->set_longitude_deg(f.point->lon_deg);
      cylinder.mutable_centre_geo()->set_altitude_m(origin_altitude_m +
                                                    0.5 * (*floor_m + *ceiling_m));
      cylinder.set_radius_m(*radius_m);
      cylinder.set_height_m(*ceiling_m - *floor_m);
      return absl::OkStatus();
    }
    for (const LatLonPolygon& p : f.polygons) {
      if (p.outer.size() > kMaxRingVertices) {
        return absl::InvalidArgumentError(absl::StrCat(field, ": ", f.label, ": ", PartName(f, p),
                                                       p.outer.size(), " vertices, more than ",
                                                       kMaxRingVertices));
      }
      v1::Obstacle& zone = zones.emplace_back();
      zone.set_id(PartId("zone", f, p));
      ToRing(p.outer, *zone.mutable_prism()->mutable_footprint());
      zone.mutable_prism()->set_base_m(*floor_m);
      zone.mutable_prism()->set_top_m(*ceiling_m);
      if (!p.holes.empty()) {
        dropped.push_back(absl::StrCat(field, ": ", f.label, ": ", PartName(f, p), "its ",
                                       Count(p.holes.size(), "hole is", "holes are"),
                                       " closed (a zone is a prism without holes)"));
      }
    }
    return absl::OkStatus();
  });
  if (!read.ok()) return read;
  return zones;
}

absl::StatusOr<std::vector<v1::Obstacle>> ReadBuildings(const std::string& path,
                                                        absl::string_view field,
                                                        const BuildingHeightRules& rules,
                                                        std::vector<std::string>& dropped) {
  absl::StatusOr<VectorFile> file = VectorFile::Open(path, field);
  if (!file.ok()) return file.status();
  std::vector<v1::Obstacle> buildings;
  int not_buildings = 0;
  int first_not_building = 0;
  const absl::Status read = file->ForEach([&](const Feature& f) {
    const std::optional<std::string> tag = f.Property("building");
    if (!tag.has_value() || tag->empty() || *tag == "no") {
      if (not_buildings++ == 0) first_not_building = f.number;
      return absl::OkStatus();
    }
    DropRejected(field, f, dropped);
    if (f.point.has_value()) {
      dropped.push_back(
          absl::StrCat(field, ": ", f.label, ": a Point is not a footprint; dropped"));
    }
    if (f.polygons.empty()) return absl::OkStatus();
    const BuildingHeight height =
        OsmBuildingHeight(f.Property("height"), f.Property("building:levels"), rules);
    for (const LatLonPolygon& p : f.polygons) {
      const std::string id = PartId("building", f, p);
      if (p.outer.size() > kMaxRingVertices) {
        dropped.push_back(absl::StrCat(
            field, ": ", f.label, ": ", PartName(f, p), "its footprint has ", p.outer.size(),
            " vertices, more than the API's ", kMaxRingVertices, "; dropped"));
        continue;
      }
      v1::Obstacle& building = buildings.emplace_back();
      building.set_id(id);
      v1::Prism& prism = *building.mutable_prism();
      ToRing(p.outer, *prism.mutable_footprint());
      prism.set_base_m(0.0);
      prism.set_top_m(height.height_m);
      if (!p.holes.empty()) {
        dropped.push_back(
            absl::StrCat(field, ": ", f.label, ": ", id, ": its ",
                         Count(p.holes.size(), "hole (a courtyard) is", "holes (courtyards) are"),
                         " closed: a prism has none"));
      }
      if (height.source == HeightSource::kDefault) {
        dropped.push_back(absl::StrCat(field, ": ", f.label, ": ", id, ": default height ",
                                       rules.default_height_m, " m (", height.note, ")"));
      } else if (!height.note.empty()) {
        dropped.push_back(absl::StrCat(field, ": ", f.label, ": ", id, ": height ", height.height_m,
                                       " m from building:levels (", height.note, ")"));
      }
    }
    return absl::OkStatus();
  });
  if (!read.ok()) return read;
  if (not_buildings > 0) {
    dropped.push_back(absl::StrCat(field, ": ", Count(not_buildings, "feature", "features"),
                                   " without a building tag skipped (the first: feature ",
                                   first_not_building, ")"));
  }
  return buildings;
}

}  // namespace oaipp::client::geo_import
