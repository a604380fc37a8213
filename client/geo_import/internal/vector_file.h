// The features of a vector map file, read through GDAL/OGR, with their
// polygons checked and given in WGS84 latitude and longitude. geo_import.cc
// turns them into the mission's messages; nothing else should need this.
//
//   absl::StatusOr<VectorFile> file = VectorFile::Open(path, "search_files.area");
//   OAIPP_RETURN_IF_ERROR(file->ForEach([&](const Feature& f) {
//     for (const LatLonPolygon& p : f.polygons) Use(p);
//     for (const std::string& why : f.rejected) dropped->push_back(f.label + ": " + why);
//     return absl::OkStatus();
//   }));
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace oaipp::client::geo_import::internal {

struct LatLon {
  double lat_deg = 0.0;
  double lon_deg = 0.0;
};

// A ring's vertices once each, in the file's order (no repeated closing
// vertex, no vertex repeating the one before it).
using LatLonRing = std::vector<LatLon>;

struct LatLonPolygon {
  LatLonRing outer;
  std::vector<LatLonRing> holes;
  // 1-based place among the polygons of the feature's geometry, counting
  // those that failed the checks: a feature's second polygon is part 2 even
  // when its first was dropped.
  int part = 1;
};

// One feature of the file, as far as the importers need it.
struct Feature {
  // 1-based place in the file, counting in order the features of every
  // layer that has a geometry column (attribute-only tables, such as the
  // layer_styles a QGIS-saved GeoPackage holds, are not read).
  int number = 0;
  // "feature 12" or "feature 12 (way/4711)": the number and the feature's
  // OSM id or name, cut to a bounded length and to printable characters.
  std::string label;
  // The polygons of a Polygon, MultiPolygon or of a GeometryCollection's
  // polygon members that passed the checks (closed rings of at least three
  // distinct vertices, enclosing area, a valid polygon by GEOS, every vertex
  // a finite latitude in [-90, 90] and longitude in [-180, 180] once in
  // WGS84), in the geometry's order.
  std::vector<LatLonPolygon> polygons;
  // How many polygons the geometry held, checked or not.
  int polygons_in_geometry = 0;
  // A Point geometry, checked as a polygon's vertices are.
  std::optional<LatLon> point;
  // One reason per polygon or geometry part that was not usable ("polygon 2
  // of 3: its outer ring crosses itself", "a LineString is not a polygon").
  std::vector<std::string> rejected;
  // Whether the geometry was empty or absent.
  bool no_geometry = false;

  // The property's value as text (numbers as GDAL prints them); nullopt
  // when the file has no such field or this feature leaves it unset.
  [[nodiscard]] std::optional<std::string> Property(absl::string_view name) const;

  // (name, value) of the fields this feature sets, in the layer's order.
  std::vector<std::pair<std::string, std::string>> properties;
};

class VectorFile {
 public:
  // Opens `path` as GeoJSON, KML, GeoPackage or an ESRI Shapefile.
  // NotFound when there is no such file; InvalidArgument when GDAL reads it
  // as none of those, when a layer's CRS cannot be transformed to WGS84, or
  // when a GeoPackage or Shapefile layer has no CRS (a Shapefile without
  // its .prj, a GeoPackage layer with an undefined SRS): only GeoJSON and
  // KML are WGS84 by definition.
  // Errors start with `field` and never quote more than a bounded piece of
  // the file.
  [[nodiscard]] static absl::StatusOr<VectorFile> Open(const std::string& path,
                                                       absl::string_view field);

  VectorFile(VectorFile&&) noexcept;
  VectorFile& operator=(VectorFile&&) noexcept;
  VectorFile(const VectorFile&) = delete;
  VectorFile& operator=(const VectorFile&) = delete;
  ~VectorFile();

  // Calls `visit` on every feature of every layer with a geometry column,
  // in file order; stops at the first error `visit` returns, and returns it.
  [[nodiscard]] absl::Status ForEach(const std::function<absl::Status(const Feature&)>& visit);

 private:
  struct Impl;
  explicit VectorFile(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// Text from a file made safe to print in one line: control characters and
// quotes become '?', cut after `max_bytes` (at a UTF-8 character boundary)
// with "..." appended.
[[nodiscard]] std::string Bounded(absl::string_view text, std::size_t max_bytes = 40);

}  // namespace oaipp::client::geo_import::internal
