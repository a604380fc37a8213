#include "client/sarenv/npy.h"

#include <bit>
#include <fstream>
#include <limits>
#include <sstream>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace oaipp::sarenv {
namespace {

constexpr absl::string_view kMagic = "\x93NUMPY";

absl::Status Bad(absl::string_view name, absl::string_view what) {
  return absl::InvalidArgumentError(absl::StrCat(name, ": not a 2-D '<f8' .npy file: ", what));
}

uint64_t LittleEndian(absl::string_view bytes, size_t offset, int width) {
  uint64_t value = 0;
  for (int i = width - 1; i >= 0; --i) {
    value = (value << 8) | static_cast<unsigned char>(bytes[offset + i]);
  }
  return value;
}

// The text after `'key':` in the header's dict literal, with leading
// blanks removed; empty when the key is absent.
absl::string_view ValueOf(absl::string_view header, absl::string_view key) {
  for (const char quote : {'\'', '"'}) {
    const std::string quoted = absl::StrCat(std::string(1, quote), key, std::string(1, quote));
    const size_t at = header.find(quoted);
    if (at == absl::string_view::npos) continue;
    absl::string_view rest = header.substr(at + quoted.size());
    rest = absl::StripLeadingAsciiWhitespace(rest);
    if (!absl::ConsumePrefix(&rest, ":")) return {};
    return absl::StripLeadingAsciiWhitespace(rest);
  }
  return {};
}

absl::StatusOr<std::vector<int64_t>> ParseShape(absl::string_view text, absl::string_view name) {
  if (!absl::ConsumePrefix(&text, "(")) return Bad(name, "the header's shape is not a tuple");
  const size_t close = text.find(')');
  if (close == absl::string_view::npos) return Bad(name, "the header's shape is not closed");
  std::vector<int64_t> dims;
  for (absl::string_view part : absl::StrSplit(text.substr(0, close), ',')) {
    part = absl::StripAsciiWhitespace(part);
    if (part.empty()) continue;  // the trailing comma of a 1-tuple or of NumPy's style
    int64_t dim = 0;
    if (!absl::SimpleAtoi(part, &dim) || dim < 0) {
      return Bad(name, absl::StrCat("the shape has a bad dimension '", part, "'"));
    }
    dims.push_back(dim);
  }
  return dims;
}

}  // namespace

absl::StatusOr<Grid2D> ParseNpy(absl::string_view bytes, absl::string_view name) {
  if (bytes.size() < 10 || bytes.substr(0, kMagic.size()) != kMagic) {
    return Bad(name, "bad magic (expected \\x93NUMPY)");
  }
  const int major = static_cast<unsigned char>(bytes[6]);
  size_t header_len = 0;
  size_t header_start = 0;
  if (major == 1) {
    header_len = LittleEndian(bytes, 8, 2);
    header_start = 10;
  } else if (major == 2) {
    if (bytes.size() < 12) return Bad(name, "truncated in the preamble");
    header_len = LittleEndian(bytes, 8, 4);
    header_start = 12;
  } else {
    return Bad(name, absl::StrCat("format version ", major, ".x is not supported (1.0 or 2.0)"));
  }
  if (bytes.size() < header_start + header_len) return Bad(name, "truncated in the header");
  const absl::string_view header = bytes.substr(header_start, header_len);

  absl::string_view descr = ValueOf(header, "descr");
  if (descr.size() < 2 || (descr[0] != '\'' && descr[0] != '"')) {
    return Bad(name, "the header has no 'descr'");
  }
  const size_t descr_end = descr.find(descr[0], 1);
  if (descr_end == absl::string_view::npos) return Bad(name, "the header's 'descr' is not closed");
  descr = descr.substr(1, descr_end - 1);
  if (descr != "<f8") {
    return Bad(name, absl::StrCat("dtype '", descr, "' (only little-endian float64 '<f8')"));
  }
  const absl::string_view fortran = ValueOf(header, "fortran_order");
  if (absl::StartsWith(fortran, "True")) return Bad(name, "Fortran order (only C order)");
  if (!absl::StartsWith(fortran, "False")) return Bad(name, "the header has no 'fortran_order'");
  absl::StatusOr<std::vector<int64_t>> shape = ParseShape(ValueOf(header, "shape"), name);
  if (!shape.ok()) return shape.status();
  if (shape->size() != 2) {
    return Bad(name, absl::StrCat("shape (", absl::StrJoin(*shape, ", "), ") is not 2-D"));
  }

  const absl::string_view data = bytes.substr(header_start + header_len);
  const int64_t rows = (*shape)[0];
  const int64_t cols = (*shape)[1];
  if (rows != 0 && cols > std::numeric_limits<int64_t>::max() / 8 / rows) {
    return Bad(name, absl::StrCat("shape (", rows, ", ", cols, ") is too large"));
  }
  const uint64_t needed = static_cast<uint64_t>(rows) * static_cast<uint64_t>(cols);
  if (data.size() != needed * sizeof(double)) {
    return Bad(name,
               absl::StrCat(data.size() < needed * sizeof(double) ? "truncated" : "too long",
                            ": shape (", rows, ", ", cols, ") needs ", needed * sizeof(double),
                            " bytes of data, the file has ", data.size()));
  }
  Grid2D grid{.rows = rows, .cols = cols, .values = std::vector<double>(needed)};
  for (uint64_t i = 0; i < needed; ++i) {
    grid.values[i] = std::bit_cast<double>(LittleEndian(data, i * sizeof(double), 8));
  }
  return grid;
}

absl::StatusOr<Grid2D> ReadNpy(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(path, ": cannot open"));
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (in.bad()) return absl::DataLossError(absl::StrCat(path, ": read error"));
  return ParseNpy(bytes.str(), path);
}

std::string EncodeNpy(const Grid2D& grid) {
  std::string header = absl::StrCat("{'descr': '<f8', 'fortran_order': False, 'shape': (",
                                    grid.rows, ", ", grid.cols, "), }");
  // Magic (6) + version (2) + length (2) + header + '\n', padded with
  // blanks to a multiple of 64 so that the data is aligned.
  const size_t unpadded = kMagic.size() + 4 + header.size() + 1;
  header.append((64 - unpadded % 64) % 64, ' ');
  header.push_back('\n');
  std::string out(kMagic);
  out.push_back('\x01');
  out.push_back('\x00');
  out.push_back(static_cast<char>(header.size() & 0xff));
  out.push_back(static_cast<char>((header.size() >> 8) & 0xff));
  out += header;
  out.reserve(out.size() + grid.values.size() * sizeof(double));
  for (const double v : grid.values) {
    uint64_t bits = std::bit_cast<uint64_t>(v);
    for (int i = 0; i < 8; ++i) {
      out.push_back(static_cast<char>(bits & 0xff));
      bits >>= 8;
    }
  }
  return out;
}

absl::Status WriteNpy(const std::string& path, const Grid2D& grid) {
  if (static_cast<size_t>(grid.rows * grid.cols) != grid.values.size()) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": grid of ", grid.rows, " x ", grid.cols,
                                                   " holds ", grid.values.size(), " values"));
  }
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) return absl::PermissionDeniedError(absl::StrCat(path, ": cannot create"));
  const std::string bytes = EncodeNpy(grid);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) return absl::DataLossError(absl::StrCat(path, ": write error"));
  return absl::OkStatus();
}

}  // namespace oaipp::sarenv
