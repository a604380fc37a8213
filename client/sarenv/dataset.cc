#include "client/sarenv/dataset.h"

#include <proj.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "absl/strings/str_cat.h"

namespace oaipp::sarenv {
namespace {

using nlohmann::json;

absl::StatusOr<std::string> ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(path, ": cannot open"));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

absl::StatusOr<json> ReadJson(const std::string& path) {
  absl::StatusOr<std::string> text = ReadText(path);
  if (!text.ok()) return text.status();
  json doc = json::parse(*text, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": not a JSON object"));
  }
  return doc;
}

absl::Status MissingField(const std::string& path, absl::string_view field,
                          absl::string_view kind) {
  return absl::InvalidArgumentError(
      absl::StrCat(path, ": field '", field, "' missing or not ", kind));
}

absl::StatusOr<double> Number(const json& doc, const std::string& path, const char* field) {
  const auto it = doc.find(field);
  if (it == doc.end() || !it->is_number()) return MissingField(path, field, "a number");
  return it->get<double>();
}

absl::StatusOr<std::string> Text(const json& doc, const std::string& path, const char* field) {
  const auto it = doc.find(field);
  if (it == doc.end() || !it->is_string()) return MissingField(path, field, "a string");
  return it->get<std::string>();
}

absl::StatusOr<Bounds> BoundsOf(const json& doc, const std::string& path) {
  const auto it = doc.find("bounds");
  if (it == doc.end() || !it->is_array() || it->size() != 4 ||
      !std::all_of(it->begin(), it->end(), [](const json& v) { return v.is_number(); })) {
    return MissingField(path, "bounds", "[minx, miny, maxx, maxy]");
  }
  Bounds b{(*it)[0].get<double>(), (*it)[1].get<double>(), (*it)[2].get<double>(),
           (*it)[3].get<double>()};
  if (!(b.max_x_m > b.min_x_m && b.max_y_m > b.min_y_m)) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": empty bounds"));
  }
  return b;
}

absl::Status LoadMeta(const std::string& path, Dataset& out) {
  absl::StatusOr<json> doc = ReadJson(path);
  if (!doc.ok()) return doc.status();
  const auto center = doc->find("center_point");
  if (center == doc->end() || !center->is_array() || center->size() != 2 ||
      !(*center)[0].is_number() || !(*center)[1].is_number()) {
    return MissingField(path, "center_point", "[lon, lat]");
  }
  out.center_lon_deg = (*center)[0].get<double>();
  out.center_lat_deg = (*center)[1].get<double>();
  absl::StatusOr<Bounds> bounds = BoundsOf(*doc, path);
  absl::StatusOr<std::string> crs = Text(*doc, path, "crs");
  absl::StatusOr<double> meter_per_bin = Number(*doc, path, "meter_per_bin");
  absl::StatusOr<double> radius_km = Number(*doc, path, "radius_km");
  absl::StatusOr<std::string> type = Text(*doc, path, "environment_type");
  absl::StatusOr<std::string> climate = Text(*doc, path, "climate");
  for (const absl::Status& s : {bounds.status(), crs.status(), meter_per_bin.status(),
                                radius_km.status(), type.status(), climate.status()}) {
    if (!s.ok()) return s;
  }
  if (!(*meter_per_bin > 0)) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": meter_per_bin must be positive"));
  }
  out.bounds = *bounds;
  out.crs = *crs;
  out.meter_per_bin = *meter_per_bin;
  out.radius_km = *radius_km;
  out.environment_type = *type;
  out.climate = *climate;
  return absl::OkStatus();
}

// Python's int() of a float: truncation toward zero, which is what the
// benchmark's astype(int) does to negative offsets too.
// (Clamped first: casting a double beyond int64's range is undefined.)
int64_t Truncate(double v) {
  return static_cast<int64_t>(std::trunc(std::clamp(std::isnan(v) ? 0.0 : v, -0x1p62, 0x1p62)));
}

}  // namespace

absl::StatusOr<Dataset> LoadDataset(const std::string& dir) {
  Dataset out;
  out.name = std::filesystem::path(dir).lexically_normal().filename().string();
  if (out.name.empty()) out.name = std::filesystem::path(dir).parent_path().filename().string();
  if (absl::Status s = LoadMeta((std::filesystem::path(dir) / "meta.json").string(), out);
      !s.ok()) {
    return s;
  }
  absl::StatusOr<Grid2D> heatmap = ReadNpy((std::filesystem::path(dir) / "heatmap.npy").string());
  if (!heatmap.ok()) return heatmap.status();
  out.heatmap = *std::move(heatmap);
  return out;
}

absl::StatusOr<double> SizeRadiusKm(absl::string_view environment_type, absl::string_view climate,
                                    absl::string_view size) {
  // Index: small, medium, large, xlarge.
  static constexpr double kFlatTemperate[] = {0.6, 1.8, 3.2, 9.9};
  static constexpr double kFlatDry[] = {1.3, 2.1, 6.6, 13.1};
  static constexpr double kMountainousTemperate[] = {1.1, 3.1, 5.8, 18.3};
  static constexpr double kMountainousDry[] = {1.6, 3.2, 6.5, 19.3};
  const double* table = nullptr;
  if (environment_type == "flat") {
    table = climate == "temperate" ? kFlatTemperate : climate == "dry" ? kFlatDry : nullptr;
  } else if (environment_type == "mountainous") {
    table = climate == "temperate" ? kMountainousTemperate
            : climate == "dry"     ? kMountainousDry
                                   : nullptr;
  }
  if (table == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat("no sizes for environment '", environment_type,
                                                   "' and climate '", climate, "'"));
  }
  static constexpr absl::string_view kSizes[] = {"small", "medium", "large", "xlarge"};
  for (int i = 0; i < 4; ++i) {
    if (size == kSizes[i]) return table[i];
  }
  return absl::InvalidArgumentError(
      absl::StrCat("unknown size '", size, "' (small, medium, large or xlarge)"));
}

absl::StatusOr<std::array<double, 2>> ProjectLonLat(double lon_deg, double lat_deg,
                                                    const std::string& crs) {
  const std::unique_ptr<PJ_CONTEXT, decltype(&proj_context_destroy)> ctx(proj_context_create(),
                                                                         &proj_context_destroy);
  if (ctx == nullptr) return absl::InternalError("PROJ: cannot create a context");
  proj_log_level(ctx.get(), PJ_LOG_NONE);
  const auto fail = [&](absl::string_view what) {
    return absl::FailedPreconditionError(
        absl::StrCat("PROJ: ", what, " EPSG:4326 -> ", crs, ": ",
                     proj_context_errno_string(ctx.get(), proj_context_errno(ctx.get())),
                     " (is proj-data installed?)"));
  };
  const std::unique_ptr<PJ, decltype(&proj_destroy)> raw(
      proj_create_crs_to_crs(ctx.get(), "EPSG:4326", crs.c_str(), nullptr), &proj_destroy);
  if (raw == nullptr) return fail("no transformation");
  // Longitude first, as pyproj's always_xy (and so the benchmark) has it.
  const std::unique_ptr<PJ, decltype(&proj_destroy)> xy(
      proj_normalize_for_visualization(ctx.get(), raw.get()), &proj_destroy);
  if (xy == nullptr) return fail("no lon/lat order for");
  const PJ_COORD out = proj_trans(xy.get(), PJ_FWD, proj_coord(lon_deg, lat_deg, 0, 0));
  if (!std::isfinite(out.xy.x) || !std::isfinite(out.xy.y)) return fail("cannot project with");
  return std::array<double, 2>{out.xy.x, out.xy.y};
}

absl::StatusOr<SearchArea> CropToDisc(const Dataset& dataset, double center_x_m, double center_y_m,
                                      double radius_m) {
  if (!(radius_m > 0)) return absl::InvalidArgumentError("crop radius must be positive");
  const Grid2D& master = dataset.heatmap;
  const double bin = dataset.meter_per_bin;
  // The disc's bounding square. The benchmark takes it from a buffered
  // point's polygon, whose extreme vertices sit exactly at +-radius.
  const Bounds square{center_x_m - radius_m, center_y_m - radius_m, center_x_m + radius_m,
                      center_y_m + radius_m};
  const auto index = [&](double v, double origin, int64_t limit) {
    return std::clamp<int64_t>(Truncate((v - origin) / bin), 0, limit);
  };
  const int64_t col0 = index(square.min_x_m, dataset.bounds.min_x_m, master.cols);
  const int64_t col1 = index(square.max_x_m, dataset.bounds.min_x_m, master.cols);
  const int64_t row0 = index(square.min_y_m, dataset.bounds.min_y_m, master.rows);
  const int64_t row1 = index(square.max_y_m, dataset.bounds.min_y_m, master.rows);
  if (col1 <= col0 || row1 <= row0) {
    return absl::InvalidArgumentError(
        absl::StrCat("dataset ", dataset.name, ": the disc lies outside the map"));
  }
  // The centre in fractional source-cell indices, compared with each cell's
  // integer index (its lower-left corner, not its centre): the benchmark's
  // mask, kept for its last digits.
  const double center_col = (center_x_m - dataset.bounds.min_x_m) / bin;
  const double center_row = (center_y_m - dataset.bounds.min_y_m) / bin;
  const double radius_cells = radius_m / bin;
  SearchArea area{.name = dataset.name,
                  .crs = dataset.crs,
                  .heatmap = {.rows = row1 - row0, .cols = col1 - col0, .values = {}},
                  .bounds = square,
                  .center_x_m = center_x_m,
                  .center_y_m = center_y_m,
                  .radius_m = radius_m,
                  .meter_per_bin = bin};
  area.heatmap.values.assign(area.heatmap.rows * area.heatmap.cols, 0.0);
  for (int64_t r = row0; r < row1; ++r) {
    const double dy = static_cast<double>(r) - center_row;
    for (int64_t c = col0; c < col1; ++c) {
      const double dx = static_cast<double>(c) - center_col;
      if (dx * dx + dy * dy <= radius_cells * radius_cells) {
        area.heatmap.At(r - row0, c - col0) = master.At(r, c);
      }
    }
  }
  return area;
}

absl::StatusOr<SearchArea> CropToSize(const Dataset& dataset, absl::string_view size) {
  absl::StatusOr<double> radius_km = SizeRadiusKm(dataset.environment_type, dataset.climate, size);
  if (!radius_km.ok()) return radius_km.status();
  absl::StatusOr<std::array<double, 2>> center =
      ProjectLonLat(dataset.center_lon_deg, dataset.center_lat_deg, dataset.crs);
  if (!center.ok()) return center.status();
  return CropToDisc(dataset, (*center)[0], (*center)[1], *radius_km * 1000);
}

absl::Status WriteSearchArea(const SearchArea& area, const std::string& npy_path,
                             const std::string& json_path) {
  if (absl::Status s = WriteNpy(npy_path, area.heatmap); !s.ok()) return s;
  const json doc = {
      {"name", area.name},
      {"crs", area.crs},
      {"bounds",
       {area.bounds.min_x_m, area.bounds.min_y_m, area.bounds.max_x_m, area.bounds.max_y_m}},
      {"center_x_m", area.center_x_m},
      {"center_y_m", area.center_y_m},
      {"radius_m", area.radius_m},
      {"meter_per_bin", area.meter_per_bin},
  };
  std::string text;
  try {
    text = doc.dump(1);                 // doubles in round-trip precision
  } catch (const json::exception& e) {  // a name or CRS that is not UTF-8
    return absl::InvalidArgumentError(absl::StrCat(json_path, ": ", e.what()));
  }
  std::ofstream out(json_path, std::ios::trunc);
  if (!out) return absl::PermissionDeniedError(absl::StrCat(json_path, ": cannot create"));
  out << text << "\n";
  out.close();
  if (!out) return absl::DataLossError(absl::StrCat(json_path, ": write error"));
  return absl::OkStatus();
}

absl::StatusOr<SearchArea> ReadSearchArea(const std::string& npy_path,
                                          const std::string& json_path) {
  absl::StatusOr<json> doc = ReadJson(json_path);
  if (!doc.ok()) return doc.status();
  absl::StatusOr<std::string> name = Text(*doc, json_path, "name");
  absl::StatusOr<std::string> crs = Text(*doc, json_path, "crs");
  absl::StatusOr<Bounds> bounds = BoundsOf(*doc, json_path);
  absl::StatusOr<double> cx = Number(*doc, json_path, "center_x_m");
  absl::StatusOr<double> cy = Number(*doc, json_path, "center_y_m");
  absl::StatusOr<double> radius = Number(*doc, json_path, "radius_m");
  absl::StatusOr<double> bin = Number(*doc, json_path, "meter_per_bin");
  for (const absl::Status& s : {name.status(), crs.status(), bounds.status(), cx.status(),
                                cy.status(), radius.status(), bin.status()}) {
    if (!s.ok()) return s;
  }
  absl::StatusOr<Grid2D> heatmap = ReadNpy(npy_path);
  if (!heatmap.ok()) return heatmap.status();
  if (heatmap->rows == 0 || heatmap->cols == 0) {
    return absl::InvalidArgumentError(absl::StrCat(npy_path, ": empty heatmap"));
  }
  return SearchArea{.name = *name,
                    .crs = *crs,
                    .heatmap = *std::move(heatmap),
                    .bounds = *bounds,
                    .center_x_m = *cx,
                    .center_y_m = *cy,
                    .radius_m = *radius,
                    .meter_per_bin = *bin};
}

}  // namespace oaipp::sarenv
