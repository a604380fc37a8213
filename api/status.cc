#include "api/status.h"

#include <optional>
#include <string>
#include <utility>

#include "absl/container/flat_hash_map.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/common/field_error.h"

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

std::string ApiFieldName(absl::string_view core_field, std::optional<int> team_member) {
  static const auto* const kState = new absl::flat_hash_map<absl::string_view, absl::string_view>{
      {"state.position_W", "state.position_m"},
      {"state.velocity_W_m_s", "state.velocity_m_s"},
      {"state.accel_W_m_s2", "state.acceleration_m_s2"},
      {"esdf.voxel_size_m", "spec.flight.esdf_voxel_m"},
      {"esdf.truncation_m", "spec.flight.esdf_truncation_m"}};
  if (const auto it = kState->find(core_field); it != kState->end()) return std::string(it->second);
  // A UAV's limits: the mission's spec.flight, or a team member's own.
  for (const absl::string_view limit :
       {"max_speed_m_s", "max_accel_m_s2", "uav_radius_m", "tracking_error_m"}) {
    if (core_field == absl::StrCat("limits.", limit)) {
      return team_member.has_value() ? absl::StrCat("spec.team[", *team_member, "].flight.", limit)
                                     : absl::StrCat("spec.flight.", limit);
    }
  }
  // An obstacle's centre, wherever the obstacle is (spec.obstacles[2], changes[0]...).
  for (const auto& [core, api] :
       {std::pair<absl::string_view, absl::string_view>{".box.centre_W", ".box.centre_m"},
        {".cylinder.centre_W", ".cylinder.centre_m"}}) {
    if (absl::EndsWith(core_field, core)) {
      return absl::StrCat(core_field.substr(0, core_field.size() - core.size()), api);
    }
  }
  return std::string(core_field);
}

absl::Status WithApiFieldNames(const absl::Status& status, std::optional<int> team_member) {
  return RenameErrorFields(
      status, [&](absl::string_view field) { return ApiFieldName(field, team_member); });
}

}  // namespace oaipp::api
