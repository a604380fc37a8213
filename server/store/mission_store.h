// Where missions live between restarts: a mission is its log (the spec at
// creation, then every applied change in order, each with a per-mission
// sequence number) plus the request_id records that let a retry after a
// restart be answered once (docs/storage.md).
//
// A MissionStore only stores and returns bytes: the records hold the API's
// own messages (serialized protobuf), so the server that reads them back
// converts them with api/ exactly as it converted the original calls.
// Appends are conditional: (mission, sequence) is unique, so a record is
// never written twice and a writer that lost track is refused.
//
//   OAIPP_ASSIGN_OR_RETURN(std::unique_ptr<MissionStore> store, OpenSqliteStore("data"));
//   OAIPP_RETURN_IF_ERROR(store->CreateMission(created));
//   OAIPP_RETURN_IF_ERROR(store->Append("m-000001", record));   // durable before the ack
//   OAIPP_ASSIGN_OR_RETURN(std::vector<StoredMission> all, store->LoadAll());
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace oaipp::server {

// What a log record holds.
enum class RecordKind : int {
  kObstacles = 1,    // payload: v1::UpdateObstaclesRequest; result: UpdateObstaclesResponse
  kMeasurement = 2,  // payload: v1::AddMeasurementRequest; result: AddMeasurementResponse
  kPlan = 3,         // payload: v1::PlanPathRequest; result: PlanPathResponse; planner_state
};

struct LogRecord {
  std::int64_t sequence = 0;  // 1, 2, ... within the mission
  RecordKind kind = RecordKind::kObstacles;
  std::string payload = {};      // the request as applied (serialized)
  std::string request_id = {};   // empty when the caller sent none
  std::string fingerprint = {};  // of the request, to tell a retry from a reuse
  std::string result = {};       // the first answer (serialized response)
  // The planner's state after this record (kPlan), as Planner::SaveState
  // gives it; empty when the planner keeps none.
  std::string planner_state = {};
};

struct StoredMission {
  std::string id = {};
  std::string spec = {};  // v1::MissionSpec with every default filled in (serialized)
  std::string request_id = {};
  std::string fingerprint = {};
  std::int64_t create_time_unix_us = 0;
  std::vector<LogRecord> log = {};  // by sequence
};

class MissionStore {
 public:
  virtual ~MissionStore() = default;

  // A number for a server-assigned mission id, never returned twice, also
  // across restarts. Unavailable when the store cannot be written.
  [[nodiscard]] virtual absl::StatusOr<std::int64_t> NextMissionNumber() = 0;
  // The mission's spec, durably. AlreadyExists when the id is taken.
  [[nodiscard]] virtual absl::Status CreateMission(const StoredMission& mission) = 0;
  // One record, durably, after those before it. AlreadyExists when the
  // mission already has `record.sequence`; NotFound for an unknown mission.
  [[nodiscard]] virtual absl::Status Append(const std::string& mission_id,
                                            const LogRecord& record) = 0;
  // Removes the mission and its records; remembers request_id (if any) as
  // having deleted it. NotFound for an unknown mission.
  [[nodiscard]] virtual absl::Status DeleteMission(const std::string& mission_id,
                                                   const std::string& request_id) = 0;
  // Every mission, with its log in sequence order.
  [[nodiscard]] virtual absl::StatusOr<std::vector<StoredMission>> LoadAll() = 0;
  // The mission a request_id deleted, or NotFound.
  [[nodiscard]] virtual absl::StatusOr<std::string> DeletedBy(const std::string& request_id) = 0;
  // OK while the store can be written (it writes to find out).
  [[nodiscard]] virtual absl::Status Health() = 0;
};

}  // namespace oaipp::server
