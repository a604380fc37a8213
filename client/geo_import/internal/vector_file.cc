#include "client/geo_import/internal/vector_file.h"

#include <cpl_error.h>
#include <gdal.h>
#include <gdal_priv.h>
#include <ogr_api.h>
#include <ogr_geometry.h>
#include <ogr_spatialref.h>
#include <ogrsf_frmts.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <system_error>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace oaipp::client::geo_import::internal {
namespace {

// The drivers a search team's files come in; anything else GDAL could open
// (rasters, databases, URLs) is refused.
constexpr const char* kDrivers[] = {"GeoJSON", "LIBKML", "KML", "GPKG", "ESRI Shapefile", nullptr};

void RegisterDriversOnce() {
  static std::once_flag once;
  std::call_once(once, [] { GDALAllRegister(); });
}

// GDAL reports problems through an error handler that prints to stderr by
// default; while this lives on a thread, they are only recorded (and read
// back with CPLGetLastErrorMsg) so that the caller decides what to say.
class QuietGdalErrors {
 public:
  QuietGdalErrors() {
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
  }
  ~QuietGdalErrors() { CPLPopErrorHandler(); }
  QuietGdalErrors(const QuietGdalErrors&) = delete;
  QuietGdalErrors& operator=(const QuietGdalErrors&) = delete;
};

// GDAL's last error, bounded, for a message of ours.
std::string LastGdalError() {
  const char* message = CPLGetLastErrorMsg();
  if (message == nullptr || *message == '\0') return "";
  return absl::StrCat(" (GDAL: ", Bounded(message, 160), ")");
}

bool SameXy(const OGRSimpleCurve& ring, int i, int j) {
  return ring.getX(i) == ring.getX(j) && ring.getY(i) == ring.getY(j);
}

// Why `ring` cannot be a polygon's ring ("is not closed"), or "".
std::string CheckRing(const OGRLinearRing& ring) {
  const int n = ring.getNumPoints();
  if (n == 0) return "is empty";
  if (!SameXy(ring, 0, n - 1)) return "is not closed (its last vertex is not its first)";
  int distinct = 0;
  for (int i = 1; i < n; ++i) distinct += SameXy(ring, i, i - 1) ? 0 : 1;
  if (distinct < 3) return absl::StrCat("has ", distinct, " distinct vertices, fewer than 3");
  // Vertices on one line: every triangle of the fan from the first vertex
  // is flat (to rounding of the ring's extent), whatever the ring's signed
  // area (a bowtie's is zero too, but it is not degenerate: it crosses).
  const double x0 = ring.getX(0), y0 = ring.getY(0);
  double fan = 0.0, extent = 0.0;
  for (int i = 1; i + 1 < n; ++i) {
    const double ax = ring.getX(i) - x0, ay = ring.getY(i) - y0;
    const double bx = ring.getX(i + 1) - x0, by = ring.getY(i + 1) - y0;
    fan += std::abs(ax * by - ay * bx);
    extent = std::max({extent, std::abs(ax), std::abs(ay)});
  }
  if (!(fan > 1e-12 * extent * extent)) return "encloses no area (its vertices lie on one line)";
  return "";
}

// OGC names ("LineString"), where GDAL's own read "Line String".
std::string TypeName(OGRwkbGeometryType type) {
  switch (wkbFlatten(type)) {
    case wkbPoint:
      return "Point";
    case wkbLineString:
      return "LineString";
    case wkbMultiPoint:
      return "MultiPoint";
    case wkbMultiLineString:
      return "MultiLineString";
    default:
      return OGRGeometryTypeToName(type);
  }
}

std::string RingName(int ring) {
  return ring == 0 ? "its outer ring" : absl::StrCat("its hole ", ring);
}

// Why `polygon` cannot be used, or "" when it can: every ring closed, with
// three distinct vertices and some area, and the polygon valid by GEOS (no
// ring crosses or touches itself; holes inside the outer ring, not inside
// each other, meeting it or each other at single points at most, which
// leave the inside in one piece).
std::string CheckPolygon(const OGRPolygon& polygon) {
  if (polygon.IsEmpty() || polygon.getExteriorRing() == nullptr) return "it is empty";
  const int holes = polygon.getNumInteriorRings();
  for (int r = 0; r <= holes; ++r) {
    const OGRLinearRing* ring = r == 0 ? polygon.getExteriorRing() : polygon.getInteriorRing(r - 1);
    if (std::string why = CheckRing(*ring); !why.empty())
      return absl::StrCat(RingName(r), " ", why);
  }
  if (polygon.IsValid()) return "";
  for (int r = 0; r <= holes; ++r) {
    const OGRLinearRing* ring = r == 0 ? polygon.getExteriorRing() : polygon.getInteriorRing(r - 1);
    // A ring is checked as a line: simple when no two of its edges meet
    // except neighbours at their shared vertex.
    OGRLineString line(*ring);
    if (!line.IsSimple()) return absl::StrCat(RingName(r), " crosses or touches itself");
  }
  return "a hole crosses or runs along the outer ring or another hole, lies outside the outer "
         "ring or inside another hole, or cuts the inside apart";
}

// Why (lon_deg, lat_deg) cannot be a WGS84 position, or "": the numbers of
// a projected layer read without its CRS (UTM metres, 465000) land here.
std::string CheckWgs84(double lon_deg, double lat_deg) {
  if (std::isfinite(lat_deg) && std::isfinite(lon_deg) && lat_deg >= -90.0 && lat_deg <= 90.0 &&
      lon_deg >= -180.0 && lon_deg <= 180.0) {
    return "";
  }
  return absl::StrFormat(
      "(longitude %.9g, latitude %.9g) is not in WGS84's [-180, 180] x [-90, 90] degrees", lon_deg,
      lat_deg);
}

// The layers a map is in: an attribute-only table (QGIS saves its styles in
// a GeoPackage's layer_styles; a Shapefile may be a lone .dbf) has no
// geometry column and holds no map features.
bool HasGeometry(OGRLayer& layer) { return wkbFlatten(layer.GetGeomType()) != wkbNone; }

// Drivers whose files say their CRS, so that a layer without one is not
// known to be WGS84; GeoJSON (RFC 7946) and KML are WGS84 by definition.
bool NeedsCrs(GDALDataset& dataset) {
  const GDALDriver* driver = dataset.GetDriver();
  if (driver == nullptr) return true;
  const absl::string_view name = driver->GetDescription();
  return name != "GeoJSON" && name != "LIBKML" && name != "KML";
}

// Whether a layer's CRS says nothing: none at all, or one of the stand-ins
// GDAL's GPKG driver gives for the GeoPackage standard's undefined SRSs
// (srs_id 0, a geographic CRS on WGS84's ellipsoid that would pass for
// WGS84; srs_id -1, a local CRS).
bool Undefined(const OGRSpatialReference* srs) {
  if (srs == nullptr) return true;
  const char* name = srs->GetName();
  if (name == nullptr) return false;
  return absl::EqualsIgnoreCase(name, "Undefined geographic SRS") ||
         absl::EqualsIgnoreCase(name, "Undefined cartesian SRS");
}

}  // namespace

// Outside the anonymous namespace: VectorFile::Impl holds these.
struct CtDeleter {
  void operator()(OGRCoordinateTransformation* ct) const {
    OGRCoordinateTransformation::DestroyCT(ct);
  }
};
using CtPtr = std::unique_ptr<OGRCoordinateTransformation, CtDeleter>;

std::string Bounded(absl::string_view text, std::size_t max_bytes) {
  std::string out;
  std::size_t end = text.size();
  bool cut = false;
  if (end > max_bytes) {
    end = max_bytes;
    // Back to the first byte of a UTF-8 character.
    while (end > 0 && (static_cast<unsigned char>(text[end]) & 0xC0) == 0x80) --end;
    cut = true;
  }
  out.reserve(end + 3);
  for (std::size_t i = 0; i < end; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    out.push_back(c < 0x20 || c == 0x7F || c == '\'' || c == '"' ? '?' : static_cast<char>(c));
  }
  if (cut) out += "...";
  return out;
}

std::optional<std::string> Feature::Property(absl::string_view name) const {
  for (const auto& [key, value] : properties) {
    if (key == name) return value;
  }
  return std::nullopt;
}

struct VectorFile::Impl {
  struct DatasetCloser {
    void operator()(GDALDataset* dataset) const { GDALClose(dataset); }
  };
  std::unique_ptr<GDALDataset, DatasetCloser> dataset;
  std::string field;
  std::string path;
  // Per layer: into WGS84 (x longitude, y latitude), or null when the layer
  // is WGS84 already.
  std::vector<CtPtr> to_wgs84;

  // Appends the usable polygons of `geometry` to `out`.
  void AddGeometry(const OGRGeometry& geometry, OGRCoordinateTransformation* ct,
                   Feature& out) const;
  // `polygon` into latitude and longitude; why not, or "".
  std::string ToLatLon(const OGRPolygon& polygon, OGRCoordinateTransformation* ct,
                       LatLonPolygon& out) const;
};

std::string VectorFile::Impl::ToLatLon(const OGRPolygon& polygon, OGRCoordinateTransformation* ct,
                                       LatLonPolygon& out) const {
  const int holes = polygon.getNumInteriorRings();
  for (int r = 0; r <= holes; ++r) {
    const OGRLinearRing& ring =
        r == 0 ? *polygon.getExteriorRing() : *polygon.getInteriorRing(r - 1);
    std::vector<double> x, y;
    const int n = ring.getNumPoints() - 1;  // the closing vertex repeats the first
    for (int i = 0; i < n; ++i) {
      if (i > 0 && SameXy(ring, i, i - 1)) continue;
      x.push_back(ring.getX(i));
      y.push_back(ring.getY(i));
    }
    if (ct != nullptr &&
        !ct->Transform(static_cast<int>(x.size()), x.data(), y.data(), nullptr, nullptr)) {
      return "it could not be transformed to WGS84";
    }
    LatLonRing lat_lon;
    lat_lon.reserve(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) {
      if (std::string why = CheckWgs84(x[i], y[i]); !why.empty()) {
        return absl::StrCat(RingName(r), "'s vertex ", i + 1, " ", why);
      }
      lat_lon.push_back({.lat_deg = y[i], .lon_deg = x[i]});
    }
    if (r == 0) {
      out.outer = std::move(lat_lon);
    } else {
      out.holes.push_back(std::move(lat_lon));
    }
  }
  return "";
}

void VectorFile::Impl::AddGeometry(const OGRGeometry& geometry, OGRCoordinateTransformation* ct,
                                   Feature& out) const {
  std::vector<const OGRPolygon*> polygons;
  const OGRwkbGeometryType type = wkbFlatten(geometry.getGeometryType());
  const auto unsupported = [&](const OGRGeometry& part, const std::string& where) {
    out.rejected.push_back(absl::StrCat(where, "a ", TypeName(part.getGeometryType()),
                                        " is neither a polygon nor a point"));
  };
  if (type == wkbPolygon) {
    polygons.push_back(geometry.toPolygon());
  } else if (type == wkbMultiPolygon) {
    for (const OGRPolygon* p : *geometry.toMultiPolygon()) polygons.push_back(p);
  } else if (type == wkbPoint) {
    const OGRPoint& point = *geometry.toPoint();
    double x = point.getX(), y = point.getY();
    if (ct != nullptr && !ct->Transform(1, &x, &y, nullptr, nullptr)) {
      out.rejected.push_back("its point could not be transformed to WGS84");
    } else if (std::string why = CheckWgs84(x, y); !why.empty()) {
      out.rejected.push_back(absl::StrCat("its point ", why));
    } else {
      out.point = LatLon{.lat_deg = y, .lon_deg = x};
    }
  } else if (type == wkbGeometryCollection) {
    // A KML MultiGeometry: its polygons count, the rest is reported.
    int member = 0;
    for (const OGRGeometry* part : *geometry.toGeometryCollection()) {
      ++member;
      const OGRwkbGeometryType part_type = wkbFlatten(part->getGeometryType());
      if (part_type == wkbPolygon) {
        polygons.push_back(part->toPolygon());
      } else if (part_type == wkbMultiPolygon) {
        for (const OGRPolygon* p : *part->toMultiPolygon()) polygons.push_back(p);
      } else {
        unsupported(*part, absl::StrCat("member ", member, " of its collection: "));
      }
    }
  } else {
    unsupported(geometry, "");
  }
  out.polygons_in_geometry = static_cast<int>(polygons.size());
  for (std::size_t i = 0; i < polygons.size(); ++i) {
    const std::string name =
        polygons.size() == 1 ? "" : absl::StrCat("polygon ", i + 1, " of ", polygons.size(), ": ");
    if (std::string why = CheckPolygon(*polygons[i]); !why.empty()) {
      out.rejected.push_back(name + why);
      continue;
    }
    LatLonPolygon p;
    if (std::string why = ToLatLon(*polygons[i], ct, p); !why.empty()) {
      out.rejected.push_back(name + why);
      continue;
    }
    p.part = static_cast<int>(i) + 1;
    out.polygons.push_back(std::move(p));
  }
}

VectorFile::VectorFile(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
VectorFile::VectorFile(VectorFile&&) noexcept = default;
VectorFile& VectorFile::operator=(VectorFile&&) noexcept = default;
VectorFile::~VectorFile() = default;

absl::StatusOr<VectorFile> VectorFile::Open(const std::string& path, absl::string_view field) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) {
    return absl::NotFoundError(absl::StrCat(field, ": no file ", Bounded(path, 300)));
  }
  RegisterDriversOnce();
  if (!OGRGeometryFactory::haveGEOS()) {
    return absl::FailedPreconditionError(
        absl::StrCat(field, ": this GDAL was built without GEOS, so polygons cannot be checked"));
  }
  const QuietGdalErrors quiet;
  auto impl = std::make_unique<Impl>();
  impl->field = std::string(field);
  impl->path = path;
  impl->dataset.reset(GDALDataset::Open(path.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY, kDrivers,
                                        nullptr, nullptr));
  if (impl->dataset == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat(
        field, ": ", Bounded(path, 300),
        " is not a GeoJSON, KML, GeoPackage or Shapefile file GDAL can read", LastGdalError()));
  }
  OGRSpatialReference wgs84;
  wgs84.importFromEPSG(4326);
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  const int layers = impl->dataset->GetLayerCount();
  const bool needs_crs = NeedsCrs(*impl->dataset);
  for (int i = 0; i < layers; ++i) {
    OGRLayer& layer = *impl->dataset->GetLayer(i);
    const OGRSpatialReference* srs = layer.GetSpatialRef();
    if (!HasGeometry(layer) || (srs == nullptr && !needs_crs)) {
      impl->to_wgs84.emplace_back();
      continue;
    }
    if (Undefined(srs)) {
      return absl::InvalidArgumentError(absl::StrCat(
          field, ": ", Bounded(path, 300), ": layer ", i + 1, " (", Bounded(layer.GetName(), 60),
          ") has no coordinate reference system (a Shapefile needs its .prj, a GeoPackage layer "
          "a defined SRS); only GeoJSON and KML are WGS84 without saying so"));
    }
    if (srs->IsSame(&wgs84)) {
      impl->to_wgs84.emplace_back();
      continue;
    }
    OGRSpatialReference source(*srs);
    // Longitude, latitude (x, y) in and out, whatever the CRS's own axis
    // order says.
    source.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    CtPtr ct(OGRCreateCoordinateTransformation(&source, &wgs84));
    if (ct == nullptr) {
      const char* name = srs->GetName();
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": ", Bounded(path, 300), ": layer ", i + 1, "'s CRS (",
                       Bounded(name != nullptr ? name : "unnamed", 60),
                       ") cannot be transformed to WGS84", LastGdalError()));
    }
    impl->to_wgs84.push_back(std::move(ct));
  }
  return VectorFile(std::move(impl));
}

absl::Status VectorFile::ForEach(const std::function<absl::Status(const Feature&)>& visit) {
  const QuietGdalErrors quiet;
  GDALDataset& dataset = *impl_->dataset;
  int number = 0;
  for (int i = 0; i < dataset.GetLayerCount(); ++i) {
    OGRLayer& layer = *dataset.GetLayer(i);
    if (!HasGeometry(layer)) continue;
    OGRCoordinateTransformation* ct = impl_->to_wgs84[static_cast<std::size_t>(i)].get();
    layer.ResetReading();
    while (true) {
      // An error recorded while fetching a feature (not while checking the
      // last one) means the file broke off.
      CPLErrorReset();
      const OGRFeatureUniquePtr ogr(layer.GetNextFeature());
      if (ogr == nullptr) {
        if (CPLGetLastErrorType() == CE_Failure || CPLGetLastErrorType() == CE_Fatal) {
          return absl::InvalidArgumentError(
              absl::StrCat(impl_->field, ": ", Bounded(impl_->path, 300), ": reading layer ", i + 1,
                           " failed after ", number, " features", LastGdalError()));
        }
        break;
      }
      Feature feature;
      feature.number = ++number;
      const OGRFeatureDefn& defn = *ogr->GetDefnRef();
      for (int f = 0; f < defn.GetFieldCount(); ++f) {
        if (!ogr->IsFieldSetAndNotNull(f)) continue;
        feature.properties.emplace_back(defn.GetFieldDefn(f)->GetNameRef(),
                                        ogr->GetFieldAsString(f));
      }
      feature.label = absl::StrCat("feature ", feature.number);
      for (const char* key : {"@id", "id", "osm_id", "name"}) {
        if (std::optional<std::string> v = feature.Property(key); v.has_value() && !v->empty()) {
          absl::StrAppend(&feature.label, " (", Bounded(*v), ")");
          break;
        }
      }
      const OGRGeometry* geometry = ogr->GetGeometryRef();
      if (geometry == nullptr || geometry->IsEmpty()) {
        feature.no_geometry = true;
      } else {
        impl_->AddGeometry(*geometry, ct, feature);
      }
      if (absl::Status status = visit(feature); !status.ok()) return status;
    }
  }
  return absl::OkStatus();
}

}  // namespace oaipp::client::geo_import::internal
