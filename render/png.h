#pragma once

// PNG bytes from an 8-bit blue-green-red image, with libpng's simplified
// write API. The server's map pictures need only this from an image codec,
// so it links libpng (a few hundred KB) rather than OpenCV's imgcodecs, which
// Debian builds with GDAL and its dozens of libraries.

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"

namespace oaipp::render {

// `bgr` holds `height` rows of `row_stride` bytes, each starting with
// `width` pixels of three bytes (blue, green, red). InvalidArgument for a
// size that is not positive or a stride shorter than a row; Internal when
// libpng refuses the image.
[[nodiscard]] absl::StatusOr<std::string> EncodePngBgr(const std::uint8_t* bgr, int width,
                                                       int height, std::size_t row_stride);

}  // namespace oaipp::render
