#include "api/status.h"

#include <string>

#include "absl/strings/str_cat.h"

namespace oaipp::api {

grpc::Status ToGrpcStatus(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()), std::string(status.message()));
}

absl::Status FromGrpcStatus(const grpc::Status& status, absl::string_view what) {
  if (status.ok()) return absl::OkStatus();
  const auto code = static_cast<absl::StatusCode>(status.error_code());
  if (what.empty()) return absl::Status(code, status.error_message());
  return absl::Status(code, absl::StrCat(what, ": ", status.error_message()));
}

namespace {

// Appends `input` with the bytes `escape` picks as \xNN, up to max_bytes.
template <typename Pred>
std::string Escaped(absl::string_view input, std::size_t max_bytes, Pred escape) {
  std::string out;
  const absl::string_view kept = input.substr(0, max_bytes);
  out.reserve(kept.size() + 16);
  for (const char c : kept) {
    const auto byte = static_cast<unsigned char>(c);
    if (escape(byte)) {
      absl::StrAppend(&out, "\\x", absl::Hex(byte, absl::kZeroPad2));
    } else {
      out.push_back(c);
    }
  }
  if (kept.size() < input.size()) absl::StrAppend(&out, "... (", input.size(), " bytes)");
  return out;
}

bool Control(unsigned char b) { return b < 0x20 || b >= 0x7f; }

}  // namespace

std::string EchoInput(absl::string_view input, std::size_t max_bytes) {
  return absl::StrCat("\"",
                      Escaped(input, max_bytes,
                              [](unsigned char b) { return Control(b) || b == '"' || b == '\\'; }),
                      "\"");
}

std::string SafeMessage(absl::string_view message, std::size_t max_bytes) {
  return Escaped(message, max_bytes, Control);
}

}  // namespace oaipp::api
