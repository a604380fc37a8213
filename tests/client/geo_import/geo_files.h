// Map files written by the tests from geometry the tests define: RFC 7946
// GeoJSON and KML 2.2 as text, and GeoPackages through GDAL itself.
// Vertices are (lat, lon) degrees; a ring is written closed (its first
// vertex repeated) unless asked not to be.
//
//   const Ring square = {{47.0, 8.0}, {47.0, 8.1}, {47.1, 8.1}, {47.1, 8.0}};
//   WriteText(dir / "b.geojson",
//             GeoJson({Polygon({square}, R"("building": "yes", "height": "12 m")")}));
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "gtest/gtest.h"
#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::client::geo_import::test_files {

struct LatLonDeg {
  double lat = 0.0;
  double lon = 0.0;
};
using Ring = std::vector<LatLonDeg>;

struct GeoFeature {
  // "Polygon" (rings[0] outer, the rest holes), "MultiPolygon" (each ring
  // its own polygon), "Point" (rings[0][0]) or "LineString" (rings[0]).
  std::string type = "Polygon";
  std::vector<Ring> rings;
  // JSON members of "properties", without the braces.
  std::string properties;
  bool close_rings = true;
};

// Features: rings[0] outer, the rest holes; each ring its own polygon;
// a ring written without its closing vertex; properties as JSON members.
[[nodiscard]] GeoFeature Polygon(std::vector<Ring> rings, std::string properties = "");
[[nodiscard]] GeoFeature MultiPolygon(std::vector<Ring> polygons, std::string properties = "");
[[nodiscard]] GeoFeature Unclosed(Ring ring);
[[nodiscard]] GeoFeature Point(LatLonDeg at, std::string properties = "");
[[nodiscard]] GeoFeature LineString(Ring line);

// A FeatureCollection; coordinates as [lon, lat] printed so that they read
// back to the same doubles.
[[nodiscard]] std::string GeoJson(const std::vector<GeoFeature>& features);

// A KML 2.2 Document with one Placemark per feature ("Polygon" or "Point"),
// named `name`, with ExtendedData Data elements from `data` pairs.
struct KmlPlacemark {
  std::string name;
  std::string type = "Polygon";
  std::vector<Ring> rings;
  std::vector<std::pair<std::string, std::string>> data;
};
[[nodiscard]] KmlPlacemark KmlPolygon(std::string name, std::vector<Ring> rings,
                                      std::vector<std::pair<std::string, std::string>> data = {});
[[nodiscard]] std::string Kml(const std::vector<KmlPlacemark>& placemarks);

void WriteText(const std::filesystem::path& path, const std::string& text);

// A GeoPackage with one polygon layer in the CRS `epsg`, written through
// GDAL's GPKG driver; rings as (x, y) in that CRS's easting/northing.
struct XyRing {
  std::vector<std::pair<double, double>> xy;
};
void WriteGeoPackage(const std::filesystem::path& path, int epsg,
                     const std::vector<std::vector<XyRing>>& polygons);

// A file written through GDAL's `driver` ("GPKG" or "ESRI Shapefile") with
// one polygon layer, each polygon a feature (rings[0] outer, the rest
// holes) with `properties` as string fields. `epsg` 0 writes no CRS: a
// Shapefile without its .prj, a GeoPackage layer with GDAL's undefined SRS.
// `attribute_rows` > 0 first writes an attribute-only table layer_styles of
// that many rows, as QGIS saves its styles into a GeoPackage.
struct XyFile {
  std::string driver = "GPKG";
  int epsg = 0;
  std::vector<std::vector<XyRing>> polygons;
  std::vector<std::pair<std::string, std::string>> properties;
  int attribute_rows = 0;
};
void WriteXyFile(const std::filesystem::path& path, const XyFile& file);

// A folder of its own for each test, TempDir()/<prefix><the test's name>,
// made before the test runs, and the lines a read says it dropped.
class FileFolderTest : public ::testing::Test {
 protected:
  explicit FileFolderTest(std::string prefix) : prefix_(std::move(prefix)) {}
  void SetUp() override;
  // Writes `text` to the folder's file `name`; its path.
  std::string Write(const std::string& name, const std::string& text);

  std::filesystem::path dir_;
  std::vector<std::string> dropped_;

 private:
  std::string prefix_;
};

// The ring is given as lat_lon_deg only, equal to `expected` vertex for
// vertex within 1e-9 deg (about 0.1 mm).
void ExpectRing(const v1::Ring& ring, const Ring& expected);

}  // namespace oaipp::client::geo_import::test_files
