// Reading and writing NumPy .npy files of one kind: a 2-D array of
// little-endian float64 ('<f8') in C (row-major) order, format version 1.0
// or 2.0. That is how the SAREnv benchmark stores its probability maps, and
// the kind the tests and the crop export write back.
//
//   absl::StatusOr<oaipp::sarenv::Grid2D> map = oaipp::sarenv::ReadNpy("1/heatmap.npy");
//   if (!map.ok()) return map.status();
//   double p = map->At(row, col);
//   absl::Status written = oaipp::sarenv::WriteNpy("crop.npy", *map);
#pragma once

#include <cstdint>
#include <string>
#include <vector>
#include "absl/strings/string_view.h"

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace oaipp::sarenv {

// A dense row-major matrix of doubles; row 0 is the first row of the file.
struct Grid2D {
  int64_t rows = 0;
  int64_t cols = 0;
  std::vector<double> values;  // rows * cols

  [[nodiscard]] double At(int64_t row, int64_t col) const { return values[row * cols + col]; }
  [[nodiscard]] double& At(int64_t row, int64_t col) { return values[row * cols + col]; }
};

// Decodes the bytes of an .npy file; `name` only labels the errors
// (InvalidArgument: bad magic, unsupported version, dtype other than
// '<f8', Fortran order, a shape that is not 2-D, or data shorter or
// longer than the shape says).
[[nodiscard]] absl::StatusOr<Grid2D> ParseNpy(absl::string_view bytes, absl::string_view name);

// Reads and decodes a file: NotFound when it cannot be opened, otherwise
// ParseNpy's errors, naming the file.
[[nodiscard]] absl::StatusOr<Grid2D> ReadNpy(const std::string& path);

// The .npy 1.0 encoding of `grid` (header padded to a multiple of 64
// bytes, as NumPy writes it).
[[nodiscard]] std::string EncodeNpy(const Grid2D& grid);

// Writes EncodeNpy(grid) to `path`.
[[nodiscard]] absl::Status WriteNpy(const std::string& path, const Grid2D& grid);

}  // namespace oaipp::sarenv
