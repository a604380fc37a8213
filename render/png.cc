#include "render/png.h"

#include <png.h>

#include <cstring>
#include <limits>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace oaipp::render {

absl::StatusOr<std::string> EncodePngBgr(const std::uint8_t* bgr, int width, int height,
                                         std::size_t row_stride) {
  if (bgr == nullptr || width <= 0 || height <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("png: an image of ", width, " x ", height, " pixels has nothing to encode"));
  }
  if (row_stride < 3 * static_cast<std::size_t>(width) ||
      row_stride > static_cast<std::size_t>(std::numeric_limits<png_int_32>::max())) {
    return absl::InvalidArgumentError(
        absl::StrCat("png: a row stride of ", row_stride, " bytes for ", width, " pixels"));
  }
  png_image image;
  std::memset(&image, 0, sizeof(image));
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = PNG_FORMAT_BGR;
  // libpng counts the stride in components (bytes here).
  const auto stride = static_cast<png_int_32>(row_stride);

  // One pass into a buffer of libpng's bound for this image (the raw rows
  // plus zlib's and the format's worst-case overhead), trimmed after.
  png_alloc_size_t size = PNG_IMAGE_PNG_SIZE_MAX(image);
  std::string bytes(size, '\0');
  if (png_image_write_to_memory(&image, bytes.data(), &size, 0, bgr, stride, nullptr) == 0) {
    const std::string why = image.message;
    png_image_free(&image);
    return absl::InternalError(absl::StrCat("png: ", why));
  }
  bytes.resize(size);
  return bytes;
}

}  // namespace oaipp::render
