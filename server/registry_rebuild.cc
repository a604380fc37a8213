// A mission read back from the store (a restart's recovery, a reload, a
// takeover): its snapshot restored, then the records after it replayed as
// the original calls were.
#include <algorithm>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/time/time.h"
#include "api/geometry.h"
#include "api/measurement.h"
#include "api/plan.h"
#include "api/spec.h"
#include "core/common/status_macros.h"
#include "server/measurement_answer.h"
#include "server/registry.h"
#include "server/store/state_codec.h"

namespace oaipp::server {

namespace {

// One stored record applied to a mission being rebuilt, as the original call
// was: the request read back and converted by api/.
absl::Status Replay(Mission& mission, const LogRecord& record) {
  switch (record.kind) {
    case RecordKind::kObstacles: {
      v1::UpdateObstaclesRequest request;
      if (!request.ParseFromString(record.payload)) break;
      OAIPP_ASSIGN_OR_RETURN(ObstacleChange change, api::ObstacleChangeFromProto(request));
      return mission.UpdateObstacles(change, {record.request_id, record.fingerprint}).status();
    }
    case RecordKind::kMeasurement: {
      v1::AddMeasurementRequest request;
      if (!request.ParseFromString(record.payload)) break;
      OAIPP_ASSIGN_OR_RETURN(MeasurementInput input, api::MeasurementFromProto(request));
      // The first answer, where it was stored (a sparse map's), is the one
      // a retry gets.
      std::optional<MeasurementResult> answer;
      if (!record.result.empty()) {
        v1::AddMeasurementResponse response;
        if (!response.ParseFromString(record.result)) break;
        answer = MeasurementResultFromProto(response);
      }
      return mission
          .AddMeasurement(input, {record.request_id, record.fingerprint}, nullptr,
                          answer.has_value() ? &*answer : nullptr)
          .status();
    }
    case RecordKind::kTeam: {
      v1::RemoveTeamMemberRequest request;
      if (!request.ParseFromString(record.payload)) break;
      return mission
          .RemoveMember(request.uav_id(), request.landed(), {record.request_id, record.fingerprint})
          .status();
    }
    case RecordKind::kPlan: {
      v1::PlanPathResponse response;
      if (!response.ParseFromString(record.result)) break;
      OAIPP_ASSIGN_OR_RETURN(PlannedPath path, api::PlannedPathFromProto(response));
      return mission.RestorePlan({record.request_id, record.fingerprint}, std::move(path),
                                 record.planner_state);
    }
  }
  return absl::DataLossError("the record does not parse");
}

}  // namespace

absl::StatusOr<MissionRegistry::ReadBack> MissionRegistry::ReadBackBase(const StoredMission& m) {
  v1::MissionSpec spec;
  if (!spec.ParseFromString(m.spec)) return absl::DataLossError("spec: does not parse");
  absl::StatusOr<MissionConfig> config = api::MissionSpecToConfig(spec);
  if (!config.ok()) return absl::DataLossError(absl::StrCat("spec: ", config.status().message()));
  ApplyServerSettings(*config);
  ReadBack out{.last_write_us = m.create_time_unix_us};
  if (m.snapshot.has_value()) {
    absl::StatusOr<MissionState> state = DecodeMissionState(m.snapshot->state);
    if (!state.ok()) return state.status();
    if (state->sequence != m.snapshot->sequence) {
      return absl::DataLossError(absl::StrCat("snapshot: covers record ", state->sequence,
                                              ", stored as covering ", m.snapshot->sequence));
    }
    absl::StatusOr<std::shared_ptr<Mission>> mission =
        Mission::Restore(m.id, *std::move(config), *std::move(state), caches_.view());
    if (!mission.ok()) {
      return absl::DataLossError(absl::StrCat("snapshot: ", mission.status().message()));
    }
    out.mission = *std::move(mission);
    out.last_write_us = std::max(out.last_write_us, m.snapshot->write_time_unix_us);
  } else {
    absl::StatusOr<std::shared_ptr<Mission>> mission =
        Mission::Create(m.id, *std::move(config), caches_.view());
    if (!mission.ok()) {
      return absl::Status(mission.status().code(),
                          absl::StrCat("creating: ", mission.status().message()));
    }
    out.mission = *std::move(mission);
  }
  return out;
}

absl::Status MissionRegistry::ReplayRecords(ReadBack& read, const std::vector<LogRecord>& log) {
  for (const LogRecord& record : log) {
    const auto failed = [&](const absl::Status& status) {
      return absl::Status(status.code(),
                          absl::StrCat("record ", record.sequence, ": ", status.message()));
    };
    if (record.sequence != read.mission->next_sequence()) {
      return failed(
          absl::DataLossError(absl::StrCat("expected sequence ", read.mission->next_sequence())));
    }
    if (absl::Status status = Replay(*read.mission, record); !status.ok()) return failed(status);
    read.last_write_us = std::max(read.last_write_us, record.write_time_unix_us);
  }
  return absl::OkStatus();
}

std::shared_ptr<Mission> MissionRegistry::Finish(ReadBack read, const StoredMission& m) {
  Mission& mission = *read.mission;
  // Set after the replay: what was stored is rebuilt even if the limit has
  // shrunk since.
  const std::int64_t estimate = EstimateMissionBytes(mission.config()).total();
  mission.set_memory_budget(estimate, LogLimit(estimate));
  mission.set_create_time(absl::FromUnixMicros(m.create_time_unix_us));
  mission.lease().set_epoch(m.epoch);
  mission.set_last_change_time(absl::FromUnixMicros(read.last_write_us));
  WatchForSnapshots(mission);
  return std::move(read.mission);
}

absl::StatusOr<std::shared_ptr<Mission>> MissionRegistry::Rebuild(const StoredMission& m) {
  OAIPP_ASSIGN_OR_RETURN(ReadBack read, ReadBackBase(m));
  OAIPP_RETURN_IF_ERROR(ReplayRecords(read, m.log));
  return Finish(std::move(read), m);
}

}  // namespace oaipp::server
