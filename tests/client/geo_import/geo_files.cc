#include "tests/client/geo_import/geo_files.h"

#include <gdal_priv.h>
#include <ogr_geometry.h>
#include <ogr_spatialref.h>
#include <ogrsf_frmts.h>

#include <fstream>
#include <stdexcept>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"

namespace oaipp::client::geo_import::test_files {
namespace {

std::string Position(const LatLonDeg& v) { return absl::StrFormat("[%.17g, %.17g]", v.lon, v.lat); }

std::string RingJson(const Ring& ring, bool close) {
  std::vector<std::string> out;
  for (const LatLonDeg& v : ring) out.push_back(Position(v));
  if (close) out.push_back(Position(ring.front()));
  return absl::StrCat("[", absl::StrJoin(out, ", "), "]");
}

std::string KmlRing(const Ring& ring) {
  std::vector<std::string> out;
  for (const LatLonDeg& v : ring) out.push_back(absl::StrFormat("%.17g,%.17g,0", v.lon, v.lat));
  out.push_back(absl::StrFormat("%.17g,%.17g,0", ring.front().lon, ring.front().lat));
  return absl::StrCat("<LinearRing><coordinates>", absl::StrJoin(out, " "),
                      "</coordinates></LinearRing>");
}

}  // namespace

GeoFeature Polygon(std::vector<Ring> rings, std::string properties) {
  GeoFeature f;
  f.rings = std::move(rings);
  f.properties = std::move(properties);
  return f;
}
GeoFeature MultiPolygon(std::vector<Ring> polygons, std::string properties) {
  GeoFeature f = Polygon(std::move(polygons), std::move(properties));
  f.type = "MultiPolygon";
  return f;
}
GeoFeature Unclosed(Ring ring) {
  GeoFeature f = Polygon({std::move(ring)});
  f.close_rings = false;
  return f;
}
GeoFeature Point(LatLonDeg at, std::string properties) {
  GeoFeature f = Polygon({{at}}, std::move(properties));
  f.type = "Point";
  return f;
}
GeoFeature LineString(Ring line) {
  GeoFeature f = Polygon({std::move(line)});
  f.type = "LineString";
  return f;
}

KmlPlacemark KmlPolygon(std::string name, std::vector<Ring> rings,
                        std::vector<std::pair<std::string, std::string>> data) {
  KmlPlacemark p;
  p.name = std::move(name);
  p.rings = std::move(rings);
  p.data = std::move(data);
  return p;
}

std::string GeoJson(const std::vector<GeoFeature>& features) {
  std::vector<std::string> out;
  for (const GeoFeature& f : features) {
    std::string coordinates;
    if (f.type == "Point") {
      coordinates = Position(f.rings.at(0).at(0));
    } else if (f.type == "LineString") {
      coordinates = RingJson(f.rings.at(0), false);
    } else {
      std::vector<std::string> rings;
      for (const Ring& r : f.rings) {
        rings.push_back(f.type == "MultiPolygon"
                            ? absl::StrCat("[", RingJson(r, f.close_rings), "]")
                            : RingJson(r, f.close_rings));
      }
      coordinates = absl::StrCat("[", absl::StrJoin(rings, ", "), "]");
    }
    out.push_back(absl::StrCat(R"({"type": "Feature", "properties": {)", f.properties,
                               R"(}, "geometry": {"type": ")", f.type, R"(", "coordinates": )",
                               coordinates, "}}"));
  }
  return absl::StrCat(R"({"type": "FeatureCollection", "features": [)", "\n",
                      absl::StrJoin(out, ",\n"), "\n]}\n");
}

std::string Kml(const std::vector<KmlPlacemark>& placemarks) {
  std::string out =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<kml xmlns=\"http://www.opengis.net/kml/2.2\">\n<Document>\n";
  for (const KmlPlacemark& p : placemarks) {
    absl::StrAppend(&out, "<Placemark><name>", p.name, "</name>");
    if (!p.data.empty()) {
      out += "<ExtendedData>";
      for (const auto& [name, value] : p.data) {
        absl::StrAppend(&out, "<Data name=\"", name, "\"><value>", value, "</value></Data>");
      }
      out += "</ExtendedData>";
    }
    if (p.type == "Point") {
      const LatLonDeg& v = p.rings.at(0).at(0);
      absl::StrAppend(
          &out,
          absl::StrFormat("<Point><coordinates>%.17g,%.17g,0</coordinates></Point>", v.lon, v.lat));
    } else {
      absl::StrAppend(&out, "<Polygon><outerBoundaryIs>", KmlRing(p.rings.at(0)),
                      "</outerBoundaryIs>");
      for (std::size_t h = 1; h < p.rings.size(); ++h) {
        absl::StrAppend(&out, "<innerBoundaryIs>", KmlRing(p.rings[h]), "</innerBoundaryIs>");
      }
      out += "</Polygon>";
    }
    out += "</Placemark>\n";
  }
  return out + "</Document>\n</kml>\n";
}

void WriteText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
}

void WriteGeoPackage(const std::filesystem::path& path, int epsg,
                     const std::vector<std::vector<XyRing>>& polygons) {
  XyFile file;
  file.epsg = epsg;
  file.polygons = polygons;
  WriteXyFile(path, file);
}

void WriteXyFile(const std::filesystem::path& path, const XyFile& file) {
  GDALAllRegister();
  std::filesystem::remove(path);
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName(file.driver.c_str());
  if (driver == nullptr) throw std::runtime_error("GDAL has no driver " + file.driver);
  GDALDatasetUniquePtr dataset(
      driver->Create(path.string().c_str(), 0, 0, 0, GDT_Unknown, nullptr));
  if (dataset == nullptr) throw std::runtime_error("cannot create " + path.string());
  if (file.attribute_rows > 0) {
    OGRLayer* styles = dataset->CreateLayer("layer_styles", nullptr, wkbNone, nullptr);
    if (styles == nullptr) throw std::runtime_error("cannot create an attribute table");
    OGRFieldDefn name("styleName", OFTString);
    styles->CreateField(&name);
    for (int i = 0; i < file.attribute_rows; ++i) {
      OGRFeature row(styles->GetLayerDefn());
      row.SetField("styleName", absl::StrCat("style ", i + 1).c_str());
      if (styles->CreateFeature(&row) != OGRERR_NONE) {
        throw std::runtime_error("cannot write a row");
      }
    }
  }
  OGRSpatialReference srs;
  if (file.epsg != 0) {
    srs.importFromEPSG(file.epsg);
    srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  }
  OGRLayer* layer =
      dataset->CreateLayer("area", file.epsg != 0 ? &srs : nullptr, wkbPolygon, nullptr);
  if (layer == nullptr) throw std::runtime_error("cannot create a layer");
  for (const auto& [key, value] : file.properties) {
    OGRFieldDefn field(key.c_str(), OFTString);
    layer->CreateField(&field);
  }
  for (const std::vector<XyRing>& rings : file.polygons) {
    OGRPolygon polygon;
    for (const XyRing& r : rings) {
      OGRLinearRing ring;
      for (const auto& [x, y] : r.xy) ring.addPoint(x, y);
      ring.closeRings();
      polygon.addRing(&ring);
    }
    OGRFeature feature(layer->GetLayerDefn());
    for (const auto& [key, value] : file.properties) {
      feature.SetField(key.c_str(), value.c_str());
    }
    feature.SetGeometry(&polygon);
    if (layer->CreateFeature(&feature) != OGRERR_NONE) {
      throw std::runtime_error("cannot write a feature");
    }
  }
}

void FileFolderTest::SetUp() {
  dir_ = std::filesystem::path(::testing::TempDir()) /
         (prefix_ + ::testing::UnitTest::GetInstance()->current_test_info()->name());
  std::filesystem::create_directories(dir_);
}

std::string FileFolderTest::Write(const std::string& name, const std::string& text) {
  WriteText(dir_ / name, text);
  return (dir_ / name).string();
}

void ExpectRing(const v1::Ring& ring, const Ring& expected) {
  constexpr double kDegTol = 1e-9;
  ASSERT_EQ(ring.lat_lon_deg_size(), 2 * static_cast<int>(expected.size()));
  EXPECT_EQ(ring.xy_m_size(), 0);
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_NEAR(ring.lat_lon_deg(2 * i), expected[i].lat, kDegTol) << "vertex " << i;
    EXPECT_NEAR(ring.lat_lon_deg(2 * i + 1), expected[i].lon, kDegTol) << "vertex " << i;
  }
}

}  // namespace oaipp::client::geo_import::test_files
