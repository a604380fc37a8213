// absl::Status <-> grpc::Status: the two share code numbers, so the code
// and the message cross unchanged.
//
//   return ToGrpcStatus(status);                      // in a service method
//   absl::Status s = FromGrpcStatus(grpc_status, "PlanPath");  // in a client
#pragma once

#include <grpcpp/support/status.h>

#include <cstddef>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace oaipp::api {

// The same code and message.
[[nodiscard]] grpc::Status ToGrpcStatus(const absl::Status& status);
// The same code; the message prefixed with "<what>: " when `what` is not
// empty (e.g. the RPC's name, for a client's error).
[[nodiscard]] absl::Status FromGrpcStatus(const grpc::Status& status, absl::string_view what = "");

// Client input that an error message repeats, made safe to send and to log:
// in double quotes, at most `max_bytes` of it, control characters, quotes,
// backslashes and non-ASCII bytes as \xNN, and when cut "..." with the full
// length. EchoInput("a\nb") == "\"a\\x0ab\"".
[[nodiscard]] std::string EchoInput(absl::string_view input, std::size_t max_bytes = 64);
// A whole status message made safe the same way (control characters and
// non-ASCII bytes escaped, cut at `max_bytes`), for the reply and the log.
[[nodiscard]] std::string SafeMessage(absl::string_view message, std::size_t max_bytes = 1024);
// The core names its fields as the code does (state.position_W,
// limits.max_speed_m_s, esdf.voxel_size_m); a caller knows them by the API's
// paths (state.position_m, spec.flight.max_speed_m_s,
// spec.flight.esdf_voxel_m), and a team member's limits by its own
// (spec.team[1].flight.max_speed_m_s). The API's path for `core_field`; a
// name the core does not use comes back unchanged.
[[nodiscard]] std::string ApiFieldName(absl::string_view core_field,
                                       std::optional<int> team_member = std::nullopt);
// The same status with the API's names for the fields it carries as data
// (core/common/field_error.h; `team_member`: the index in spec.team of the
// UAV the error is about). A status without fields comes back unchanged.
[[nodiscard]] absl::Status WithApiFieldNames(const absl::Status& status,
                                             std::optional<int> team_member = std::nullopt);

}  // namespace oaipp::api
