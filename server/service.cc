#include "server/service.h"

#include <chrono>

#include "absl/strings/cord.h"
#include "absl/strings/escaping.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "api/export.h"
#include "api/geodetic.h"
#include "api/geometry.h"
#include "api/map.h"
#include "api/measurement.h"
#include "api/metadata.h"
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
absl::Time Deadline(const grpc::ServerContextBase* context) {
  const auto deadline = context->deadline();
  if (deadline == std::chrono::system_clock::time_point::max()) return absl::InfiniteFuture();
  return absl::FromChrono(deadline);
}

// When the planner must stop: the call's deadline less a margin for the
// exact check and the reply to reach the client (10 % of the time left,
// between 50 and 250 ms), so that an anytime plan still arrives in time.
absl::Time PlanningDeadline(const grpc::ServerContextBase* context) {
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

// After a mutation failed: the registry drops a copy another server took
// over, or reads back a mission whose write was in doubt; the caller sees
// what the registry says.
template <typename T>
absl::StatusOr<T> AfterWrite(MissionRegistry& registry, const std::shared_ptr<Mission>& mission,
                             absl::StatusOr<T> result) {
  if (result.ok()) return result;
  return registry.AfterFailedWrite(mission, result.status());
}

// The writer of one mutation's record, or nullptr without a store: the
// request as received, its request_id and fingerprint, at the sequence number
// the mission gives it and the ownership epoch this copy holds.
template <typename Request>
PersistFn Recorder(MissionStore* store, const Mission& mission, RecordKind kind,
                   const Request& request, const std::string& fingerprint) {
  if (store == nullptr) return nullptr;
  return [store, &mission, kind, &request, &fingerprint](std::int64_t sequence) {
    return AppendStatus(store->Append(mission.id(), {.sequence = sequence,
                                                     .kind = kind,
                                                     .payload = request.SerializeAsString(),
                                                     .request_id = request.request_id(),
                                                     .fingerprint = fingerprint,
                                                     .epoch = mission.epoch()}));
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
  out->set_name(absl::StrCat("missions/", MissionRegistry::PublicId(s.id)));
  *out->mutable_spec() = ConfigToMissionSpec(s.config);
  for (const Obstacle& o : s.obstacles) *out->add_obstacles() = ObstacleToProto(o);
  out->set_trace(s.trace);
  out->set_measurements_fused(s.measurements_fused);
  out->set_paths_planned(s.paths_planned);
  out->set_mission_time_s(s.mission_time_s);
  out->set_map_bytes(s.memory_bytes);
  *out->mutable_create_time() = TimeUtil::NanosecondsToTimestamp(absl::ToUnixNanos(s.create_time));
}

// `request` with its geodetic points (*_geo) in the mission's local metres:
// itself when it has none, else a converted copy in `scratch`. Done before
// anything else sees the request, and before it is stored, so that a replay
// needs no origin.
template <typename Request>
absl::StatusOr<const Request*> InLocalMetres(const Mission& mission, const Request& request,
                                             Request& scratch) {
  if (!api::HasGeoFields(request)) return &request;
  scratch = request;
  OAIPP_RETURN_IF_ERROR(api::ResolveGeoFields(mission.config().geo_origin, &scratch));
  return &scratch;
}

void FillEvent(const MissionEventData& e, v1::MissionEvent* out) {
  out->set_sequence(e.sequence);
  *out->mutable_time() = TimeUtil::NanosecondsToTimestamp(absl::ToUnixNanos(e.time));
  if (const auto* m = std::get_if<MissionEventData::MeasurementFused>(&e.event)) {
    auto* f = out->mutable_measurement_fused();
    f->set_mission_time_s(m->mission_time_s);
    f->set_cells_fused(m->cells_fused);
    f->set_trace(m->trace);
    *f->mutable_camera_position_m() = ToProto(m->camera_position_W);
    f->mutable_detected_cells()->Add(m->detected_cells.begin(), m->detected_cells.end());
  } else if (const auto* o = std::get_if<MissionEventData::ObstaclesChanged>(&e.event)) {
    out->mutable_obstacles_changed()->set_obstacle_count(o->obstacle_count);
  } else if (const auto* p = std::get_if<MissionEventData::PathPlanned>(&e.event)) {
    auto* f = out->mutable_path_planned();
    f->set_mission_time_s(p->mission_time_s);
    f->set_duration_s(p->duration_s);
    f->set_objective(p->objective);
    for (const Vec3& w : p->control_waypoints_W) *f->add_control_waypoints_m() = ToProto(w);
    *f->mutable_start_m() = ToProto(p->start_W);
  } else {
    out->mutable_mission_deleted();
  }
}

}  // namespace

template <typename Body>
absl::Status MissionServiceImpl::Run(const char* method, Body body, bool record_ok) {
  const absl::Time start = absl::Now();
  absl::Status status;
  try {
    status = body();
  } catch (const std::bad_alloc&) {
    // Admission control should keep this from happening; if it does, the
    // caller learns it is about resources, not a bug.
    status = absl::ResourceExhaustedError(
        absl::StrCat(method, ": the server ran out of memory for this call; retry later"));
  } catch (const std::exception& e) {
    // A bug must not take the server down with every other mission.
    status = absl::InternalError(absl::StrCat(method, ": ", e.what()));
  }
  if (status.ok() && !record_ok) return status;
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
    status =
        absl::Status(status.code(), api::SafeMessage(api::WithApiFieldNames(status).message()));
    // A fault of the server's own (not of the request) is an error worth
    // an operator's attention; a refused request is routine.
    const bool own_fault =
        absl::IsInternal(status) || absl::IsDataLoss(status) || absl::IsUnknown(status);
    spdlog::log(own_fault ? spdlog::level::err : spdlog::level::info,
                "rpc method={} code={} ms={:.2f} error=\"{}\"", method,
                absl::StatusCodeToString(status.code()), seconds * 1e3,
                absl::StrReplaceAll(status.message(), {{"\"", "\\\""}}));
  }
  return status;
}

template <typename Body>
grpc::Status MissionServiceImpl::Call(grpc::ServerContextBase* context, const char* method,
                                      Body body) {
  TagReplica(context);
  return ToGrpcStatus(Run(method, std::move(body)));
}

void MissionServiceImpl::TagReplica(grpc::ServerContextBase* context) const {
  if (!limits_.replica_id.empty())
    context->AddInitialMetadata(api::kReplicaHeader, limits_.replica_id);
}

absl::StatusOr<std::string> MissionServiceImpl::TenantOf(
    const grpc::ServerContextBase& context) const {
  if (auth_ == nullptr) return std::string();
  return auth_->TenantOf(context);
}

absl::Status MissionServiceImpl::AcquireStream(const std::string& client) {
  absl::MutexLock lock(&quota_mu_);
  if (streams_ >= limits_.max_streams) {
    return absl::ResourceExhaustedError(absl::StrCat("WatchMission: the server has its limit of ",
                                                     limits_.max_streams,
                                                     " open streams; close one or retry later"));
  }
  int& mine = streams_by_client_[client];
  if (mine >= limits_.max_streams_per_client) {
    if (mine == 0) streams_by_client_.erase(client);
    return absl::ResourceExhaustedError(absl::StrCat("WatchMission: you have ", mine,
                                                     " open streams, the limit per client; "
                                                     "close one first"));
  }
  ++mine;
  ++streams_;
  return absl::OkStatus();
}

void MissionServiceImpl::ReleaseStream(const std::string& client) {
  absl::MutexLock lock(&quota_mu_);
  --streams_;
  if (--streams_by_client_[client] <= 0) streams_by_client_.erase(client);
}

absl::Status MissionServiceImpl::AcquirePlan(const std::string& tenant) {
  absl::MutexLock lock(&quota_mu_);
  int& mine = plans_by_tenant_[tenant];
  if (limits_.max_plans_per_tenant > 0 && mine >= limits_.max_plans_per_tenant) {
    if (mine == 0) plans_by_tenant_.erase(tenant);
    return absl::ResourceExhaustedError(absl::StrCat(
        "PlanPath: you have ", mine, " plans queued or running, your quota; retry when one ends"));
  }
  ++mine;
  return absl::OkStatus();
}

void MissionServiceImpl::ReleasePlan(const std::string& tenant) {
  absl::MutexLock lock(&quota_mu_);
  if (--plans_by_tenant_[tenant] <= 0) plans_by_tenant_.erase(tenant);
}

bool MissionServiceImpl::Overloaded() const {
  if (planners_->waiting() >= planners_->queue_capacity() &&
      planners_->running() >= planners_->threads()) {
    return true;
  }
  absl::MutexLock lock(&quota_mu_);
  return streams_ >= limits_.max_streams;
}

double MissionServiceImpl::SearchFraction() const {
  if (!(limits_.shed_above > 0.0)) return 1.0;
  const double waiting = planners_->waiting();
  const double allowed = limits_.shed_above * planners_->threads();
  if (waiting <= allowed) return 1.0;
  return std::clamp(allowed / waiting, limits_.min_search_fraction, 1.0);
}

void MissionServiceImpl::NotePlanQueued(absl::Time arrived) {
  absl::MutexLock lock(&quota_mu_);
  newest_plan_ = std::max(newest_plan_, arrived);
}

std::optional<MissionServiceImpl::TakeOffRefusal> MissionServiceImpl::AdmitTakeOff(
    std::optional<absl::Time> grounded_since) {
  // UAVs in the air hover while they wait for a path: a take-off also
  // waits while as many plans queue as there are planning threads, unless
  // it has waited the patience since its first refusal.
  const int waiting = planners_->waiting();
  const int threads = planners_->threads();
  const absl::Time now = absl::Now();
  const bool patience_over =
      grounded_since.has_value() && now - *grounded_since >= limits_.take_off_patience;
  absl::MutexLock lock(&quota_mu_);
  const int limit = limits_.max_take_off_plans;
  if (take_offs_ < limit && (waiting < threads || patience_over)) {
    ++take_offs_;
    return std::nullopt;
  }
  // Refused callers queue up virtually: each is told to come back one
  // take-off plan's share of the threads it may use after the one before,
  // never more than kMaxTakeOffDelay ahead (callers that ignore the delay
  // cannot push everyone else's further).
  take_off_slot_ =
      std::min(std::max(take_off_slot_, now) + take_off_cost_ / std::min(limit, threads),
               now + kMaxTakeOffDelay);
  return TakeOffRefusal{
      .retry_after = take_off_slot_ - now,
      .reason = take_offs_ >= limit
                    ? absl::StrCat(take_offs_, " take-off plans (the limit) are being planned")
                    : absl::StrCat(waiting, " plans wait for ", threads, " planning threads")};
}

void MissionServiceImpl::TakeOffEnded(absl::Duration planned) {
  absl::MutexLock lock(&quota_mu_);
  --take_offs_;
  if (planned > absl::ZeroDuration()) take_off_cost_ = 0.8 * take_off_cost_ + 0.2 * planned;
}

// Plans are taken up in about arrival order (one plan per mission at a
// time), so the newest has about the latest bound: the plan starting now
// and the `behind` queued after it share the planning threads until then.
// Plans already running on other threads are not counted, so a queue that
// forms behind them can end somewhat past the bound.
absl::Duration MissionServiceImpl::FairShare() const {
  const absl::Duration bound = limits_.plan_latency;
  const int behind = planners_->waiting();
  if (bound <= absl::ZeroDuration() || behind == 0) return absl::InfiniteDuration();
  absl::Time newest;
  {
    absl::MutexLock lock(&quota_mu_);
    newest = newest_plan_;
  }
  return (newest + bound - absl::Now()) * planners_->threads() / (behind + 1);
}

int MissionServiceImpl::open_streams() const {
  absl::MutexLock lock(&quota_mu_);
  return streams_;
}

grpc::Status MissionServiceImpl::CreateMission(grpc::ServerContext* context,
                                               const v1::CreateMissionRequest* request,
                                               v1::Mission* response) {
  return Call(context, "CreateMission", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(const std::string tenant, TenantOf(*context));
    OAIPP_ASSIGN_OR_RETURN(MissionConfig config, MissionSpecToConfig(request->spec()));
    OAIPP_ASSIGN_OR_RETURN(
        std::shared_ptr<Mission> mission,
        registry_->Create(request->mission_id(), std::move(config), request->request_id(),
                          RequestFingerprint(*request), tenant));
    FillMission(*mission, response);
    if (metrics_ != nullptr) {
      metrics_->SetMissions(static_cast<double>(registry_->size()),
                            static_cast<double>(registry_->MemoryBytes()));
    }
    spdlog::info("mission event=created name={} tenant={}", response->name(), tenant);
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::GetMission(grpc::ServerContext* context,
                                            const v1::GetMissionRequest* request,
                                            v1::Mission* response) {
  return Call(context, "GetMission", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(const std::string tenant, TenantOf(*context));
    OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission,
                           registry_->Get(request->name(), tenant));
    FillMission(*mission, response);
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::ListMissions(grpc::ServerContext* context,
                                              const v1::ListMissionsRequest* request,
                                              v1::ListMissionsResponse* response) {
  return Call(context, "ListMissions", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(const std::string tenant, TenantOf(*context));
    if (request->page_size() < 0 || request->page_size() > 1000) {
      return absl::InvalidArgumentError(
          absl::StrCat("page_size: must be in [0, 1000], got ", request->page_size()));
    }
    const std::size_t size = request->page_size() == 0 ? 50 : request->page_size();
    std::int64_t after = 0;
    if (!request->page_token().empty()) {
      OAIPP_ASSIGN_OR_RETURN(after, ParsePageToken(request->page_token()));
    }
    const auto missions = registry_->ListAfter(after, size + 1, tenant);
    for (std::size_t i = 0; i < missions.size() && i < size; ++i) {
      FillMission(*missions[i].second, response->add_missions());
    }
    if (missions.size() > size) response->set_next_page_token(PageToken(missions[size - 1].first));
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::DeleteMission(grpc::ServerContext* context,
                                               const v1::DeleteMissionRequest* request,
                                               v1::DeleteMissionResponse*) {
  return Call(context, "DeleteMission", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(const std::string tenant, TenantOf(*context));
    OAIPP_RETURN_IF_ERROR(registry_->Delete(request->name(), request->request_id(), tenant));
    if (metrics_ != nullptr) {
      metrics_->SetMissions(static_cast<double>(registry_->size()),
                            static_cast<double>(registry_->MemoryBytes()));
    }
    spdlog::info("mission event=deleted name={} tenant={}", request->name(), tenant);
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::UpdateObstacles(grpc::ServerContext* context,
                                                 const v1::UpdateObstaclesRequest* request,
                                                 v1::UpdateObstaclesResponse* response) {
  return Call(context, "UpdateObstacles", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(const std::string tenant, TenantOf(*context));
    OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission,
                           registry_->Get(request->name(), tenant));
    v1::UpdateObstaclesRequest resolved;
    OAIPP_ASSIGN_OR_RETURN(const v1::UpdateObstaclesRequest* in_metres,
                           InLocalMetres(*mission, *request, resolved));
    const v1::UpdateObstaclesRequest& local = *in_metres;
    OAIPP_ASSIGN_OR_RETURN(ObstacleChange change, ObstacleChangeFromProto(local));
    const std::string fingerprint = RequestFingerprint(local);
    OAIPP_ASSIGN_OR_RETURN(
        ObstacleResult result,
        AfterWrite(*registry_, mission,
                   mission->UpdateObstacles(change, {local.request_id(), fingerprint},
                                            Recorder(registry_->store(), *mission,
                                                     RecordKind::kObstacles, local, fingerprint))));
    response->set_obstacle_count(result.obstacle_count);
    response->set_esdf_voxels_recomputed(result.esdf_voxels_recomputed);
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::AddMeasurement(grpc::ServerContext* context,
                                                const v1::AddMeasurementRequest* request,
                                                v1::AddMeasurementResponse* response) {
  return Call(context, "AddMeasurement", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(const std::string tenant, TenantOf(*context));
    OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission,
                           registry_->Get(request->name(), tenant));
    v1::AddMeasurementRequest resolved;
    OAIPP_ASSIGN_OR_RETURN(const v1::AddMeasurementRequest* in_metres,
                           InLocalMetres(*mission, *request, resolved));
    const v1::AddMeasurementRequest& local = *in_metres;
    OAIPP_ASSIGN_OR_RETURN(MeasurementInput input, MeasurementFromProto(local));
    const std::string fingerprint = RequestFingerprint(local);
    OAIPP_ASSIGN_OR_RETURN(MeasurementResult result,
                           AfterWrite(*registry_, mission,
                                      mission->AddMeasurement(
                                          input, {local.request_id(), fingerprint},
                                          Recorder(registry_->store(), *mission,
                                                   RecordKind::kMeasurement, local, fingerprint))));
    response->set_cells_fused(result.cells_fused);
    response->set_trace(result.trace);
    response->set_measurements_fused(result.measurements_fused);
    (void)settlers_.Submit(mission->id(), [mission] { mission->SettleMap(); });
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::ExportPath(grpc::ServerContext* context,
                                            const v1::ExportPathRequest* request,
                                            v1::ExportPathResponse* response) {
  return Call(context, "ExportPath", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(const std::string tenant, TenantOf(*context));
    OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission,
                           registry_->Get(request->name(), tenant));
    if (!request->has_path()) {
      return absl::InvalidArgumentError("path: required (a PlanPath answer of this mission)");
    }
    OAIPP_ASSIGN_OR_RETURN(const api::ExportOptions options, api::ExportOptionsFromProto(*request));
    const MissionSnapshot snapshot = mission->Snapshot();
    OAIPP_ASSIGN_OR_RETURN(
        *response, api::ExportPath(snapshot.config, snapshot.obstacles, request->path(), options));
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::GetMap(grpc::ServerContext* context,
                                        const v1::GetMapRequest* request,
                                        v1::GetMapResponse* response) {
  return Call(context, "GetMap", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(const std::string tenant, TenantOf(*context));
    OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission,
                           registry_->Get(request->name(), tenant));
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
    OAIPP_ASSIGN_OR_RETURN(
        std::string png,
        render::RenderMapPng(
            grid, layers, overlay,
            {.mission = absl::StrCat("missions/", MissionRegistry::PublicId(snapshot.id)),
             .mission_time_s = snapshot.mission_time_s,
             .trace = response->trace()}));
    response->set_png(std::move(png));
    return absl::OkStatus();
  });
}

// One PlanPath call: checked at once, then a job in the planning pool. While
// it waits it holds no thread; a client that cancels (or whose deadline
// passes) takes it out of the queue, or stops the planner within one CMA-ES
// generation once it runs.
class MissionServiceImpl::PlanReactor final : public grpc::ServerUnaryReactor {
 public:
  PlanReactor(MissionServiceImpl* service, grpc::CallbackServerContext* context,
              const v1::PlanPathRequest* request, v1::PlanPathResponse* response)
      : service_(service),
        context_(context),
        request_(request),
        response_(response),
        arrived_(absl::Now()) {
    service_->TagReplica(context_);
    // A plan that was queued is counted (metrics, log) when it ends.
    const absl::Status status = service_->Run(
        "PlanPath", [&] { return Start(); }, /*record_ok=*/false);
    if (!status.ok()) {
      if (take_off_) service_->TakeOffEnded(absl::ZeroDuration());
      Finish(ToGrpcStatus(status));
    }
  }

  void OnCancel() override {
    cancelled_ = true;
    bool dropped = false;
    {
      absl::MutexLock lock(&mu_);
      dropped = job_.Cancel();
    }
    if (dropped) {
      End(
          absl::CancelledError("PlanPath: cancelled (by the client, or its deadline passed) "
                               "while waiting for a planner"));
    }
  }

  void OnDone() override { delete this; }

 private:
  // Everything checked before the plan is queued; an error here finishes
  // the call at once.
  absl::Status Start() {
    OAIPP_ASSIGN_OR_RETURN(tenant_, service_->TenantOf(*context_));
    OAIPP_ASSIGN_OR_RETURN(mission_, service_->registry_->Get(request_->name(), tenant_));
    if (!request_->has_state()) return absl::InvalidArgumentError("state: required");
    v1::UavState state = request_->state();
    OAIPP_RETURN_IF_ERROR(api::ResolveGeoFields(mission_->config().geo_origin, &state, "state"));
    OAIPP_ASSIGN_OR_RETURN(state_, UavStateFromProto(state, "state"));
    if (request_->has_next_shot_mission_s()) next_shot_ = request_->next_shot_mission_s();
    call_.deadline = PlanningDeadline(context_);
    call_.cancelled = [this] { return cancelled_.load() || context_->IsCancelled(); };
    if (request_->has_planning_budget_s()) {
      const double budget = request_->planning_budget_s();
      if (!(budget > 0.0) || !std::isfinite(budget)) {
        return absl::InvalidArgumentError(
            absl::StrCat("planning_budget_s: must be > 0 and finite, got ", budget));
      }
      call_.budget = absl::Seconds(budget);
    }
    call_.budget = std::min(call_.budget, service_->limits_.max_planning);
    fingerprint_ = RequestFingerprint(*request_);
    if (MissionStore* store = service_->registry_->store(); store != nullptr) {
      call_.persist = [this, store](std::int64_t sequence, const PlannedPath& planned,
                                    const std::string& planner_state) {
        v1::PlanPathResponse answer;
        PlannedPathToProto(planned, &answer);
        return AppendStatus(store->Append(mission_->id(), {.sequence = sequence,
                                                           .kind = RecordKind::kPlan,
                                                           .payload = request_->SerializeAsString(),
                                                           .request_id = request_->request_id(),
                                                           .fingerprint = fingerprint_,
                                                           .result = answer.SerializeAsString(),
                                                           .planner_state = planner_state,
                                                           .epoch = mission_->epoch()}));
      };
    }
    // A UAV at rest at mission time 0 has not flown: it can wait on the
    // ground for its first path.
    if (service_->limits_.max_take_off_plans > 0 && state_.mission_time_s == 0.0 &&
        state_.velocity_W_m_s.isZero() && state_.accel_W_m_s2.isZero()) {
      std::optional<TakeOffRefusal> refused = service_->AdmitTakeOff(mission_->grounded_since());
      if (refused.has_value()) {
        mission_->NoteTakeOffRefused(absl::Now());
        const std::int64_t ms =
            std::max<std::int64_t>(1, absl::ToInt64Milliseconds(refused->retry_after));
        context_->AddTrailingMetadata(api::kRetryAfterHeader, absl::StrCat(ms));
        return absl::ResourceExhaustedError(
            absl::StrCat("PlanPath: take-off paced (", refused->reason,
                         "); this UAV is at rest at mission time 0: retry in ", ms, " ms (",
                         api::kRetryAfterHeader, ")"));
      }
      take_off_ = true;
    }
    OAIPP_RETURN_IF_ERROR(service_->AcquirePlan(tenant_));
    holds_plan_ = true;
    absl::MutexLock lock(&mu_);
    absl::StatusOr<PlanningPool::Handle> job =
        service_->planners_->Submit(mission_->id(), [this] { Plan(); });
    if (!job.ok()) {
      service_->ReleasePlan(tenant_);
      holds_plan_ = false;
      return job.status();
    }
    job_ = *std::move(job);
    service_->NotePlanQueued(arrived_);
    return absl::OkStatus();
  }

  // On a planning thread.
  void Plan() {
    const absl::Status status = service_->Run("PlanPath", [&]() -> absl::Status {
      if (call_.cancelled()) return absl::CancelledError("PlanPath: cancelled by the client");
      call_.search_fraction = service_->SearchFraction();
      call_.queued = absl::Now() - arrived_;
      if (const absl::Duration bound = service_->limits_.plan_latency;
          bound > absl::ZeroDuration()) {
        // The plan and those queued behind it share the time left until
        // the newest one's bound (FairShare), and none searches past its
        // own. A plan with (almost) nothing left still plans for a
        // hundredth of the bound: its greedy start scores at least one
        // candidate per waypoint, and a straight segment to the first is
        // the last resort. Unless the wait took (almost) all of the bound,
        // the search ends within it; the exact check and the reply come
        // after it.
        const absl::Duration left =
            std::max(std::min(bound - call_.queued, service_->FairShare()), bound / 100);
        if (left < call_.budget) {
          call_.budget = left;
          call_.budget_is_servers = true;
        }
      }
      if (absl::Now() >= call_.deadline) {
        return absl::DeadlineExceededError("PlanPath: the deadline passed waiting for a planner");
      }
      OAIPP_ASSIGN_OR_RETURN(
          PlannedPath path,
          AfterWrite(
              *service_->registry_, mission_,
              mission_->Plan(state_, next_shot_, {request_->request_id(), fingerprint_}, call_)));
      if (service_->metrics_ != nullptr) {
        service_->metrics_->RecordPlan(path.stats.wall_time_s,
                                       static_cast<double>(path.stats.evaluations));
      }
      planned_ = absl::Seconds(path.stats.wall_time_s);
      PlannedPathToProto(path, response_);
      return absl::OkStatus();
    });
    End(status);
  }

  // The last thing either path does: after Finish the reactor may be gone.
  void End(const absl::Status& status) {
    if (holds_plan_) service_->ReleasePlan(tenant_);
    if (take_off_) {
      service_->TakeOffEnded(planned_);
      if (status.ok()) mission_->NoteTookOff();  // a failed one waits on
    }
    Finish(ToGrpcStatus(status));
  }

  MissionServiceImpl* const service_;
  grpc::CallbackServerContext* const context_;
  const v1::PlanPathRequest* const request_;
  v1::PlanPathResponse* const response_;
  std::string tenant_;
  std::shared_ptr<Mission> mission_;
  UavState state_;
  std::optional<double> next_shot_;
  const absl::Time arrived_;
  Mission::PlanCall call_;
  std::string fingerprint_;
  bool holds_plan_ = false;
  // Admitted by take-off pacing (counted until End), and how long it planned.
  bool take_off_ = false;
  absl::Duration planned_ = absl::ZeroDuration();
  std::atomic<bool> cancelled_{false};
  absl::Mutex mu_;
  PlanningPool::Handle job_ ABSL_GUARDED_BY(mu_);
};

grpc::ServerUnaryReactor* MissionServiceImpl::PlanPath(grpc::CallbackServerContext* context,
                                                       const v1::PlanPathRequest* request,
                                                       v1::PlanPathResponse* response) {
  return new PlanReactor(this, context, request, response);
}

// One WatchMission stream: woken by its event queue's listener, it writes
// one event at a time and holds no thread between events.
class MissionServiceImpl::WatchReactor final : public grpc::ServerWriteReactor<v1::MissionEvent> {
 public:
  WatchReactor(MissionServiceImpl* service, grpc::CallbackServerContext* context,
               const v1::WatchMissionRequest* request)
      : service_(service) {
    service_->TagReplica(context);
    const absl::Status opened = service_->Run("WatchMission", [&]() -> absl::Status {
      OAIPP_ASSIGN_OR_RETURN(const std::string tenant, service_->TenantOf(*context));
      OAIPP_ASSIGN_OR_RETURN(mission_, service_->registry_->Get(request->name(), tenant));
      // Per client: the tenant with tokens, the connection without.
      client_ = tenant.empty() ? context->peer() : tenant;
      OAIPP_RETURN_IF_ERROR(service_->AcquireStream(client_));
      holds_stream_ = true;
      return absl::OkStatus();
    });
    if (!opened.ok()) {
      Finish(ToGrpcStatus(opened));
      return;
    }
    link_ = std::make_shared<Link>();
    link_->reactor = this;
    queue_ = mission_->Subscribe();
    queue_->SetListener([link = std::weak_ptr<Link>(link_)] {
      if (std::shared_ptr<Link> l = link.lock()) l->Wake();
    });
    Wake();
  }

  void OnWriteDone(bool ok) override {
    absl::MutexLock lock(&link_->mu);
    writing_ = false;
    if (!ok) {
      FinishOnce(grpc::Status::OK);
      return;
    }
    PumpLocked();
  }

  void OnCancel() override {
    if (link_ == nullptr) return;
    absl::MutexLock lock(&link_->mu);
    FinishOnce(grpc::Status::OK);
  }

  void OnDone() override {
    if (link_ != nullptr) {
      {
        absl::MutexLock lock(&link_->mu);
        link_->reactor = nullptr;
      }
      queue_->SetListener(nullptr);
      queue_->Close();
      mission_->Unsubscribe(queue_);
    }
    if (holds_stream_) service_->ReleaseStream(client_);
    delete this;
  }

 private:
  // Shared with the queue's listener, which may outlive the reactor.
  struct Link {
    absl::Mutex mu;
    WatchReactor* reactor ABSL_GUARDED_BY(mu) = nullptr;
    void Wake() {
      absl::MutexLock lock(&mu);
      if (reactor != nullptr) reactor->PumpLocked();
    }
  };

  void Wake() { link_->Wake(); }

  // Starts the next write when none is in flight (gRPC runs its reactions
  // on its own threads, never inside StartWrite, so holding the link's lock
  // here is safe).
  void PumpLocked() {
    if (writing_ || finished_) return;
    std::optional<MissionEventData> event = queue_->TryPop();
    if (!event.has_value()) {
      if (queue_->closed()) FinishOnce(ToGrpcStatus(queue_->close_reason()));
      return;
    }
    out_.Clear();
    FillEvent(*event, &out_);
    writing_ = true;
    if (std::holds_alternative<MissionEventData::Deleted>(event->event)) {
      finished_ = true;
      StartWriteAndFinish(&out_, grpc::WriteOptions(), grpc::Status::OK);
      return;
    }
    StartWrite(&out_);
  }

  void FinishOnce(const grpc::Status& status) {
    if (finished_) return;
    finished_ = true;
    Finish(status);
  }

  MissionServiceImpl* const service_;
  std::shared_ptr<Mission> mission_;
  std::string client_;
  bool holds_stream_ = false;
  std::shared_ptr<Link> link_;
  std::shared_ptr<EventQueue> queue_;
  v1::MissionEvent out_;
  bool writing_ = false;   // under link_->mu
  bool finished_ = false;  // under link_->mu
};

grpc::ServerWriteReactor<v1::MissionEvent>* MissionServiceImpl::WatchMission(
    grpc::CallbackServerContext* context, const v1::WatchMissionRequest* request) {
  return new WatchReactor(this, context, request);
}

}  // namespace oaipp::server
