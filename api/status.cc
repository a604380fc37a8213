#include "api/status.h"

#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"

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

absl::Status WithApiFieldNames(const absl::Status& status) {
  if (status.ok()) return status;
  // Longest first where one name starts another.
  const std::string message = absl::StrReplaceAll(
      status.message(), {{"state.position_W", "state.position_m"},
                         {"state.velocity_W_m_s", "state.velocity_m_s"},
                         {"state.accel_W_m_s2", "state.acceleration_m_s2"},
                         {"limits.max_speed_m_s", "spec.flight.max_speed_m_s"},
                         {"limits.max_accel_m_s2", "spec.flight.max_accel_m_s2"},
                         {"limits.uav_radius_m", "spec.flight.uav_radius_m"},
                         {"limits.tracking_error_m", "spec.flight.tracking_error_m"},
                         {"esdf.voxel_size_m", "spec.flight.esdf_voxel_m"},
                         {"esdf.truncation_m", "spec.flight.esdf_truncation_m"},
                         {"esdf: ", "spec.flight.esdf_voxel_m: "},
                         {".box.centre_W", ".box.centre_m"},
                         {".cylinder.centre_W", ".cylinder.centre_m"}});
  absl::Status out(status.code(), message);
  status.ForEachPayload(
      [&](absl::string_view url, const absl::Cord& payload) { out.SetPayload(url, payload); });
  return out;
}

}  // namespace oaipp::api
