#include "server/service.h"

#include <chrono>

#include "absl/strings/cord.h"
#include "absl/strings/escaping.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "api/geometry.h"
#include "api/map.h"
#include "api/measurement.h"
#include "api/plan.h"
#include "api/spec.h"
#include "api/status.h"
#include "core/common/status_macros.h"
#include "google/protobuf/util/time_util.h"
#include "render/map_render.h"
#include "server/store/fingerprint.h"
#include "spdlog/spdlog.h"

namespace oaipp::server {
namespace {

using api::ConfigToMissionSpec;
using api::MapToProto;
using api::MeasurementFromProto;
using api::MeasurementInput;
using api::MissionConfig;
using api::MissionSpecToConfig;
using api::ObstacleChangeFromProto;
using api::ObstacleToProto;
using api::PlannedPathToProto;
using api::ToGrpcStatus;
using api::ToProto;
using api::UavStateFromProto;

using google::protobuf::util::TimeUtil;

// The call's deadline as absl::Time (infinite when the client set none).
absl::Time Deadline(const grpc::ServerContext* context) {
  const auto deadline = context->deadline();
  if (deadline == std::chrono::system_clock::time_point::max()) return absl::InfiniteFuture();
  return absl::FromChrono(deadline);
}

// When the planner must stop: the call's deadline less a margin for the
// exact check and the reply to reach the client (10 % of the time left,
// between 50 and 250 ms), so that an anytime plan still arrives in time.
absl::Time PlanningDeadline(const grpc::ServerContext* context) {
  const absl::Time deadline = Deadline(context);
  if (deadline == absl::InfiniteFuture()) return deadline;
  const absl::Duration left = deadline - absl::Now();
  return deadline - std::clamp(left / 10, absl::Milliseconds(50), absl::Milliseconds(250));
}

// A failed append as the caller sees it. A record already at that place
// that is not this request means the mission in memory is behind its log
// (an earlier write's outcome was in doubt): like a write in doubt, the
// mission must be read back before it is written again.
absl::Status AppendStatus(absl::Status status) {
  if (status.code() == absl::StatusCode::kAlreadyExists) {
    status = absl::UnavailableError(
        "store: the mission's log holds a record this server did not apply; the mission is read "
        "back from the store; retry");
    status.SetPayload(kInDoubt, absl::Cord("conflict"));
  }
  return status;
}

// After a mutation failed: reads the mission back when the store may hold
// more than memory.
template <typename T>
void ReloadIfInDoubt(MissionRegistry& registry, const std::string& mission_id,
                     const absl::StatusOr<T>& result) {
  if (result.ok() || !result.status().GetPayload(kInDoubt).has_value()) return;
  if (absl::Status reloaded = registry.Reload(mission_id); !reloaded.ok()) {
    spdlog::warn("store: {}", reloaded.ToString());
  } else {
    spdlog::info("store: mission '{}' read back after a write in doubt", mission_id);
  }
}

// The writer of one mutation's record, or nullptr without a store: the
// request as received, its request_id and fingerprint, at the sequence number
// the mission gives it.
template <typename Request>
PersistFn Recorder(MissionStore* store, const std::string& mission_id, RecordKind kind,
                   const Request& request, const std::string& fingerprint) {
  if (store == nullptr) return nullptr;
  return [store, &mission_id, kind, &request, &fingerprint](std::int64_t sequence) {
    return AppendStatus(store->Append(mission_id, {.sequence = sequence,
                                                   .kind = kind,
                                                   .payload = request.SerializeAsString(),
                                                   .request_id = request.request_id(),
                                                   .fingerprint = fingerprint}));
  };
}

// ListMissions page tokens: the creation number of the last mission shown
// (numbers are never reused, so deleting missions between pages neither
// hides nor repeats one), with a check value, in URL-safe base64. A token
// this server did not make is refused.
constexpr absl::string_view kPageTokenKey = "oaipp.v1.ListMissions";

std::string PageToken(std::int64_t after) {
  const std::string body = absl::StrCat("p1.", after);
  return absl::WebSafeBase64Escape(
      absl::StrCat(body, ".", FingerprintBytes(absl::StrCat(kPageTokenKey, body))));
}

absl::StatusOr<std::int64_t> ParsePageToken(const std::string& token) {
  const absl::Status bad = absl::InvalidArgumentError(
      "page_token: not a token this server gave out (pass next_page_token unchanged)");
  std::string decoded;
  if (token.size() > 128 || !absl::WebSafeBase64Unescape(token, &decoded)) return bad;
  const std::vector<absl::string_view> parts = absl::StrSplit(decoded, '.');
  std::int64_t after = 0;
  if (parts.size() != 3 || parts[0] != "p1" || !absl::SimpleAtoi(parts[1], &after) || after < 0 ||
      parts[2] != FingerprintBytes(absl::StrCat(kPageTokenKey, parts[0], ".", parts[1]))) {
    return bad;
  }
  return after;
}

void FillMission(const Mission& mission, v1::Mission* out) {
  const MissionSnapshot s = mission.Snapshot();
  out->set_name(absl::StrCat("missions/", s.id));
  *out->mutable_spec() = ConfigToMissionSpec(s.config);
  for (const Obstacle& o : s.obstacles) *out->add_obstacles() = ObstacleToProto(o);
  out->set_trace(s.trace);
  out->set_measurements_fused(s.measurements_fused);
  out->set_paths_planned(s.paths_planned);
  out->set_mission_time_s(s.mission_time_s);
  out->set_map_bytes(s.memory_bytes);
  *out->mutable_create_time() = TimeUtil::NanosecondsToTimestamp(absl::ToUnixNanos(s.create_time));
}

void FillEvent(const MissionEventData& e, v1::MissionEvent* out) {
  out->set_sequence(e.sequence);
  *out->mutable_time() = TimeUtil::NanosecondsToTimestamp(absl::ToUnixNanos(e.time));
  if (const auto* m = std::get_if<MissionEventData::MeasurementFused>(&e.event)) {
    auto* f = out->mutable_measurement_fused();
    f->set_mission_time_s(m->mission_time_s);
    f->set_cells_fused(m->cells_fused);
    f->set_trace(m->trace);
  } else if (const auto* o = std::get_if<MissionEventData::ObstaclesChanged>(&e.event)) {
    out->mutable_obstacles_changed()->set_obstacle_count(o->obstacle_count);
  } else if (const auto* p = std::get_if<MissionEventData::PathPlanned>(&e.event)) {
    auto* f = out->mutable_path_planned();
    f->set_mission_time_s(p->mission_time_s);
    f->set_duration_s(p->duration_s);
    f->set_objective(p->objective);
    for (const Vec3& w : p->control_waypoints_W) *f->add_control_waypoints_m() = ToProto(w);
  } else {
    out->mutable_mission_deleted();
  }
}

}  // namespace

template <typename Body>
grpc::Status MissionServiceImpl::Call(const char* method, Body body) {
  const absl::Time start = absl::Now();
  absl::Status status;
  try {
    status = body();
  } catch (const std::exception& e) {
    // A bug must not take the server down with every other mission.
    status = absl::InternalError(absl::StrCat(method, ": ", e.what()));
  }
  const double seconds = absl::ToDoubleSeconds(absl::Now() - start);
  if (metrics_ != nullptr) {
    metrics_->RecordCall(method, static_cast<int>(status.code()), seconds);
  }
  // One line per call, key=value, so that logs can be filtered and parsed.
  if (status.ok()) {
    spdlog::debug("rpc method={} code=OK ms={:.2f}", method, seconds * 1e3);
  } else {
    // Whatever the message repeats, the reply and the log line stay short
    // and one line (no control characters; quotes escaped in the log).
    status = absl::Status(status.code(), api::SafeMessage(status.message()));
    spdlog::info("rpc method={} code={} ms={:.2f} error=\"{}\"", method,
                 absl::StatusCodeToString(status.code()), seconds * 1e3,
                 absl::StrReplaceAll(status.message(), {{"\"", "\\\""}}));
  }
  return ToGrpcStatus(status);
}

grpc::Status MissionServiceImpl::CreateMission(grpc::ServerContext*,
                                               const v1::CreateMissionRequest* request,
                                               v1::Mission* response) {
  return Call("CreateMission", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(MissionConfig config, MissionSpecToConfig(request->spec()));
    OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission,
                           registry_->Create(request->mission_id(), std::move(config),
                                             request->request_id(), RequestFingerprint(*request)));
    FillMission(*mission, response);
    if (metrics_ != nullptr) {
      metrics_->SetMissions(static_cast<double>(registry_->size()),
                            static_cast<double>(registry_->MemoryBytes()));
    }
    spdlog::info("mission event=created name={}", response->name());
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::GetMission(grpc::ServerContext*,
                                            const v1::GetMissionRequest* request,
                                            v1::Mission* response) {
  return Call("GetMission", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission, registry_->Get(request->name()));
    FillMission(*mission, response);
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::ListMissions(grpc::ServerContext*,
                                              const v1::ListMissionsRequest* request,
                                              v1::ListMissionsResponse* response) {
  return Call("ListMissions", [&]() -> absl::Status {
    if (request->page_size() < 0 || request->page_size() > 1000) {
      return absl::InvalidArgumentError(
          absl::StrCat("page_size: must be in [0, 1000], got ", request->page_size()));
    }
    const std::size_t size = request->page_size() == 0 ? 50 : request->page_size();
    std::int64_t after = 0;
    if (!request->page_token().empty()) {
      OAIPP_ASSIGN_OR_RETURN(after, ParsePageToken(request->page_token()));
    }
    const auto missions = registry_->ListAfter(after, size + 1);
    for (std::size_t i = 0; i < missions.size() && i < size; ++i) {
      FillMission(*missions[i].second, response->add_missions());
    }
    if (missions.size() > size) response->set_next_page_token(PageToken(missions[size - 1].first));
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::DeleteMission(grpc::ServerContext*,
                                               const v1::DeleteMissionRequest* request,
                                               v1::DeleteMissionResponse*) {
  return Call("DeleteMission", [&]() -> absl::Status {
    OAIPP_RETURN_IF_ERROR(registry_->Delete(request->name(), request->request_id()));
    if (metrics_ != nullptr) {
      metrics_->SetMissions(static_cast<double>(registry_->size()),
                            static_cast<double>(registry_->MemoryBytes()));
    }
    spdlog::info("mission event=deleted name={}", request->name());
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::UpdateObstacles(grpc::ServerContext*,
                                                 const v1::UpdateObstaclesRequest* request,
                                                 v1::UpdateObstaclesResponse* response) {
  return Call("UpdateObstacles", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission, registry_->Get(request->name()));
    OAIPP_ASSIGN_OR_RETURN(ObstacleChange change, ObstacleChangeFromProto(*request));
    const std::string fingerprint = RequestFingerprint(*request);
    absl::StatusOr<ObstacleResult> updated = mission->UpdateObstacles(
        change, {request->request_id(), fingerprint},
        Recorder(registry_->store(), mission->id(), RecordKind::kObstacles, *request, fingerprint));
    ReloadIfInDoubt(*registry_, mission->id(), updated);
    OAIPP_ASSIGN_OR_RETURN(ObstacleResult result, std::move(updated));
    response->set_obstacle_count(result.obstacle_count);
    response->set_esdf_voxels_recomputed(result.esdf_voxels_recomputed);
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::AddMeasurement(grpc::ServerContext*,
                                                const v1::AddMeasurementRequest* request,
                                                v1::AddMeasurementResponse* response) {
  return Call("AddMeasurement", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission, registry_->Get(request->name()));
    OAIPP_ASSIGN_OR_RETURN(MeasurementInput input, MeasurementFromProto(*request));
    const std::string fingerprint = RequestFingerprint(*request);
    absl::StatusOr<MeasurementResult> fused =
        mission->AddMeasurement(input, {request->request_id(), fingerprint},
                                Recorder(registry_->store(), mission->id(),
                                         RecordKind::kMeasurement, *request, fingerprint));
    ReloadIfInDoubt(*registry_, mission->id(), fused);
    OAIPP_ASSIGN_OR_RETURN(MeasurementResult result, std::move(fused));
    response->set_cells_fused(result.cells_fused);
    response->set_trace(result.trace);
    response->set_measurements_fused(result.measurements_fused);
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::PlanPath(grpc::ServerContext* context,
                                          const v1::PlanPathRequest* request,
                                          v1::PlanPathResponse* response) {
  return Call("PlanPath", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission, registry_->Get(request->name()));
    if (!request->has_state()) return absl::InvalidArgumentError("state: required");
    OAIPP_ASSIGN_OR_RETURN(UavState state, UavStateFromProto(request->state(), "state"));
    std::optional<double> next_shot;
    if (request->has_next_shot_mission_s()) next_shot = request->next_shot_mission_s();
    Mission::PlanCall call{.deadline = PlanningDeadline(context),
                           .gate = gate_,
                           .cancelled = [context] { return context->IsCancelled(); }};
    if (request->has_planning_budget_s()) {
      const double budget = request->planning_budget_s();
      if (!(budget > 0.0) || !std::isfinite(budget)) {
        return absl::InvalidArgumentError(
            absl::StrCat("planning_budget_s: must be > 0 and finite, got ", budget));
      }
      call.budget = absl::Seconds(budget);
    }
    if (context->IsCancelled()) return absl::CancelledError("PlanPath: cancelled by the client");
    const std::string fingerprint = RequestFingerprint(*request);
    if (MissionStore* store = registry_->store(); store != nullptr) {
      call.persist = [&, store](std::int64_t sequence, const PlannedPath& planned,
                                const std::string& planner_state) {
        v1::PlanPathResponse answer;
        PlannedPathToProto(planned, &answer);
        return AppendStatus(store->Append(mission->id(), {.sequence = sequence,
                                                          .kind = RecordKind::kPlan,
                                                          .payload = request->SerializeAsString(),
                                                          .request_id = request->request_id(),
                                                          .fingerprint = fingerprint,
                                                          .result = answer.SerializeAsString(),
                                                          .planner_state = planner_state}));
      };
    }
    absl::StatusOr<PlannedPath> planned =
        mission->Plan(state, next_shot, {request->request_id(), fingerprint}, call);
    ReloadIfInDoubt(*registry_, mission->id(), planned);
    OAIPP_ASSIGN_OR_RETURN(PlannedPath path, std::move(planned));
    if (metrics_ != nullptr) {
      metrics_->RecordPlan(path.stats.wall_time_s, static_cast<double>(path.stats.evaluations));
    }
    PlannedPathToProto(path, response);
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::GetMap(grpc::ServerContext*, const v1::GetMapRequest* request,
                                        v1::GetMapResponse* response) {
  return Call("GetMap", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission, registry_->Get(request->name()));
    render::MapLayers layers;
    mission->ReadMap([&](const GpMap& map) {
      MapToProto(map, request->include_cells(), response);
      if (!request->include_png()) return;
      // Copied under the lock, drawn outside it.
      layers.mean.assign(map.Mean().begin(), map.Mean().end());
      layers.std_dev.resize(static_cast<std::size_t>(map.num_cells()));
      for (int i = 0; i < map.num_cells(); ++i) {
        layers.std_dev[static_cast<std::size_t>(i)] = std::sqrt(std::max(0.0, map.Variance(i)));
      }
    });
    if (!request->include_png()) return absl::OkStatus();
    const MissionSnapshot snapshot = mission->Snapshot();
    render::Overlay overlay;
    for (const Obstacle& o : snapshot.obstacles) {
      overlay.obstacle_footprints.push_back(GroundFootprint(o.shape));
    }
    const render::MapGrid grid{.nx = response->nx(),
                               .ny = response->ny(),
                               .resolution_m = response->resolution_m(),
                               .x_min_m = response->x_min_m(),
                               .y_min_m = response->y_min_m()};
    OAIPP_ASSIGN_OR_RETURN(std::string png,
                           render::RenderMapPng(grid, layers, overlay,
                                                {.mission = absl::StrCat("missions/", snapshot.id),
                                                 .mission_time_s = snapshot.mission_time_s,
                                                 .trace = response->trace()}));
    response->set_png(std::move(png));
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::WatchMission(grpc::ServerContext* context,
                                              const v1::WatchMissionRequest* request,
                                              grpc::ServerWriter<v1::MissionEvent>* writer) {
  std::shared_ptr<Mission> mission;
  grpc::Status opened = Call("WatchMission", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(mission, registry_->Get(request->name()));
    return absl::OkStatus();
  });
  if (!opened.ok()) return opened;
  std::shared_ptr<EventQueue> queue = mission->Subscribe();
  // Wake up now and then to notice a client that went away.
  while (!context->IsCancelled()) {
    std::optional<MissionEventData> event = queue->Pop(absl::Now() + absl::Milliseconds(200));
    if (!event.has_value()) {
      if (queue->closed()) break;
      continue;
    }
    v1::MissionEvent out;
    FillEvent(*event, &out);
    if (!writer->Write(out)) break;
    if (std::holds_alternative<MissionEventData::Deleted>(event->event)) break;
  }
  mission->Unsubscribe(queue);
  return grpc::Status::OK;
}

}  // namespace oaipp::server
