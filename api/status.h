// absl::Status <-> grpc::Status: the two share code numbers, so the code
// and the message cross unchanged.
//
//   return ToGrpcStatus(status);                      // in a service method
//   absl::Status s = FromGrpcStatus(grpc_status, "PlanPath");  // in a client
#pragma once

#include <grpcpp/support/status.h>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace oaipp::api {

// The same code and message.
[[nodiscard]] grpc::Status ToGrpcStatus(const absl::Status& status);
// The same code; the message prefixed with "<what>: " when `what` is not
// empty (e.g. the RPC's name, for a client's error).
[[nodiscard]] absl::Status FromGrpcStatus(const grpc::Status& status, absl::string_view what = "");

}  // namespace oaipp::api
