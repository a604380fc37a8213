// The gRPC metadata headers of the API beside the messages (documented in
// proto/oaipp/v1/mission_service.proto and docs/cluster.md).
#pragma once

#include <cstdint>
#include <optional>

#include "absl/strings/numbers.h"
#include "absl/strings/string_view.h"
#include "grpcpp/client_context.h"

namespace oaipp::api {

// Request header: the mission a call is about, the mission id
// (CreateMission: the mission_id asked for, or the request_id when the
// server chooses the id). A proxy in front of several servers hashes it, so
// that one mission's calls reach one server.
inline constexpr char kRouteHeader[] = "x-oaipp-mission";

// Response header (initial metadata): the server that answered, when it was
// given a --replica_id.
inline constexpr char kReplicaHeader[] = "x-oaipp-replica";

// Response header (trailing metadata) on a RESOURCE_EXHAUSTED that only a
// later retry can help: how long to wait first, whole milliseconds. Sent on
// a take-off plan refused by take-off pacing (docs/capacity.md).
inline constexpr char kRetryAfterHeader[] = "x-oaipp-retry-after-ms";

// The delay the trailing metadata of a finished call names
// (kRetryAfterHeader), in milliseconds; nullopt when the header is absent or
// not a positive whole number.
[[nodiscard]] inline std::optional<std::int64_t> RetryAfterMs(const grpc::ClientContext& context) {
  const auto& trailers = context.GetServerTrailingMetadata();
  const auto it = trailers.find(kRetryAfterHeader);
  std::int64_t ms = 0;
  if (it == trailers.end() ||
      !absl::SimpleAtoi(absl::string_view(it->second.data(), it->second.size()), &ms) || ms <= 0) {
    return std::nullopt;
  }
  return ms;
}

}  // namespace oaipp::api
