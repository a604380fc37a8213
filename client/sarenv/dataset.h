// SAREnv datasets: one folder per place holding the lost-person probability
// map of the largest ("xlarge") disc around the last known point
// (heatmap.npy) and its metadata (meta.json). A benchmark run cuts the map
// down to a smaller disc (a "size"), the SearchArea that the planners fly
// over and the metrics score.
//
//   absl::StatusOr<Dataset> dataset = LoadDataset("../shared/sarenv/1");
//   absl::StatusOr<SearchArea> area = CropToSize(*dataset, "medium");
//   // area->heatmap is 120 x 120 for dataset 1, area->radius_m 1800.
//   absl::Status saved = WriteSearchArea(*area, "crop.npy", "crop.json");
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "client/sarenv/npy.h"

namespace oaipp::sarenv {

// An axis-aligned rectangle in a projected CRS's metres.
struct Bounds {
  double min_x_m = 0;
  double min_y_m = 0;
  double max_x_m = 0;
  double max_y_m = 0;
};

struct Dataset {
  std::string name;  // the folder's name, "1" .. "60"
  double center_lon_deg = 0;
  double center_lat_deg = 0;
  std::string crs;  // "EPSG:326zz" / "EPSG:327zz": the UTM zone of the centre
  Bounds bounds;    // of the whole map, in `crs`
  double meter_per_bin = 0;
  double radius_km = 0;          // of the disc the whole map covers
  std::string environment_type;  // "flat" or "mountainous"
  std::string climate;           // "temperate" or "dry"
  Grid2D heatmap;                // row 0 is the south edge
};

// Reads heatmap.npy and meta.json from `dir`. InvalidArgument when a file
// is malformed or a field is missing, NotFound when a file is absent.
[[nodiscard]] absl::StatusOr<Dataset> LoadDataset(const std::string& dir);

// The radius of a size ("small", "medium", "large", "xlarge") for an
// environment type and climate, in km: the benchmark's table (flat and
// temperate: 0.6, 1.8, 3.2, 9.9).
[[nodiscard]] absl::StatusOr<double> SizeRadiusKm(absl::string_view environment_type,
                                                  absl::string_view climate,
                                                  absl::string_view size);

// Longitude/latitude (WGS84, degrees) to x/y in `crs`'s metres, with PROJ.
// The benchmark projects with PROJ (through pyproj) and its crops depend on
// the last bits of the result (dataset.cc says why), so this does too.
[[nodiscard]] absl::StatusOr<std::array<double, 2>> ProjectLonLat(double lon_deg, double lat_deg,
                                                                  const std::string& crs);

// The map that planners and metrics use: a disc's crop of a Dataset.
//
// Its grid is the evaluator's, not the source map's: `bounds` is the disc's
// bounding square, and cell (r, c) spans
//   [min_x + c * cell_x, min_x + (c + 1) * cell_x) x [min_y + r * cell_y, ...)
// with cell_x = (max_x - min_x) / cols. This is how the benchmark scores
// paths, although the cropped cells' true positions can lie up to one
// source cell away from that grid.
struct SearchArea {
  std::string name;
  std::string crs;
  Grid2D heatmap;  // cells outside the disc are 0; not renormalised
  Bounds bounds;
  double center_x_m = 0;
  double center_y_m = 0;
  double radius_m = 0;
  double meter_per_bin = 0;  // of the source map: sets the sample spacing

  [[nodiscard]] double CellSizeX_m() const {
    return (bounds.max_x_m - bounds.min_x_m) / heatmap.cols;
  }
  [[nodiscard]] double CellSizeY_m() const {
    return (bounds.max_y_m - bounds.min_y_m) / heatmap.rows;
  }
};

// Crops `dataset` to the disc of `radius_m` around (center_x_m,
// center_y_m) in the dataset's CRS, as the benchmark does: the source cells
// whose indices lie between those of the disc's bounding square's corners
// (index = trunc((x - source min_x) / meter_per_bin)), with every cell whose
// index lies farther than the radius (in cells) from the centre's
// fractional index set to 0.
[[nodiscard]] absl::StatusOr<SearchArea> CropToDisc(const Dataset& dataset, double center_x_m,
                                                    double center_y_m, double radius_m);

// CropToDisc around the dataset's centre (projected with ProjectLonLat)
// with the radius of `size`.
[[nodiscard]] absl::StatusOr<SearchArea> CropToSize(const Dataset& dataset, absl::string_view size);

// A SearchArea as two files: its heatmap as .npy and the rest as JSON
// (name, crs, bounds, centre, radius, meter_per_bin; doubles written so
// that they read back to the same bits).
[[nodiscard]] absl::Status WriteSearchArea(const SearchArea& area, const std::string& npy_path,
                                           const std::string& json_path);
[[nodiscard]] absl::StatusOr<SearchArea> ReadSearchArea(const std::string& npy_path,
                                                        const std::string& json_path);

}  // namespace oaipp::sarenv
