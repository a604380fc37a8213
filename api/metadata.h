// The gRPC metadata headers of the API beside the messages (documented in
// proto/oaipp/v1/mission_service.proto and docs/cluster.md).
#pragma once

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

}  // namespace oaipp::api
