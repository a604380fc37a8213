// What the MissionService's files share (service.cc, plan_reactor.cc,
// watch_reactor.cc): deadlines, the writer of a mutation's record, the
// conversion of geodetic fields, events as messages, and the body every
// RPC runs in (MissionServiceImpl::Run and Mutate). Not for other users.
#pragma once

#include <algorithm>
#include <chrono>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "api/geodetic.h"
#include "api/geometry.h"
#include "api/limits.h"
#include "api/status.h"
#include "core/common/status_macros.h"
#include "google/protobuf/util/time_util.h"
#include "server/measurement_answer.h"
#include "server/service.h"
#include "server/store/fingerprint.h"
#include "spdlog/spdlog.h"

namespace oaipp::server {
namespace service_internal {

// InvalidArgument naming request_id when it is longer than
// api::kMaxRequestIdBytes (the id itself is not echoed).
inline absl::Status CheckRequestId(const std::string& request_id) {
  if (request_id.size() <= static_cast<std::size_t>(api::kMaxRequestIdBytes)) {
    return absl::OkStatus();
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "request_id: must be at most ", api::kMaxRequestIdBytes, " bytes, got ", request_id.size()));
}

using api::ToProto;
using google::protobuf::util::TimeUtil;

// The call's deadline as absl::Time (infinite when the client set none).
inline absl::Time Deadline(const grpc::ServerContextBase* context) {
  const auto deadline = context->deadline();
  if (deadline == std::chrono::system_clock::time_point::max()) return absl::InfiniteFuture();
  return absl::FromChrono(deadline);
}

// When the planner must stop: the call's deadline less a margin for the
// exact check and the reply to reach the client (10 % of the time left,
// between 50 and 250 ms), so that an anytime plan still arrives in time.
inline absl::Time PlanningDeadline(const grpc::ServerContextBase* context) {
  const absl::Time deadline = Deadline(context);
  if (deadline == absl::InfiniteFuture()) return deadline;
  const absl::Duration left = deadline - absl::Now();
  return deadline - std::clamp(left / 10, absl::Milliseconds(50), absl::Milliseconds(250));
}

// A failed append as the caller sees it. A record already at that place
// that is not this request means the mission in memory is behind its log
// (an earlier write's outcome was in doubt): like a write in doubt, the
// mission must be read back before it is written again.
inline absl::Status AppendStatus(absl::Status status) {
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
// the mission gives it and the ownership epoch this copy holds, with the
// answer when the mission gives one (PersistFn).
template <typename Request>
PersistFn Recorder(MissionStore* store, const Mission& mission, RecordKind kind,
                   const Request& request, const std::string& fingerprint) {
  if (store == nullptr) return nullptr;
  return [store, &mission, kind, &request, &fingerprint](std::int64_t sequence,
                                                         const MeasurementResult* answer) {
    std::string result;
    if (answer != nullptr) {
      v1::AddMeasurementResponse response;
      FillMeasurementResponse(*answer, &response);
      result = response.SerializeAsString();
    }
    return AppendStatus(store->Append(mission.id(), {.sequence = sequence,
                                                     .kind = kind,
                                                     .payload = request.SerializeAsString(),
                                                     .request_id = request.request_id(),
                                                     .fingerprint = fingerprint,
                                                     .result = std::move(result),
                                                     .epoch = mission.lease().epoch()}));
  };
}

// `request` with its geodetic points (*_geo) in the mission's local metres:
// itself when it has none, else a converted copy in `scratch`. Done before
// anything else sees the request, and before it is stored, so that a replay
// needs no origin.
template <typename Request>
absl::StatusOr<const Request*> InLocalMetres(const Mission& mission, const Request& request,
                                             Request& scratch) {
  if constexpr (!requires { api::HasGeoFields(request); }) {
    return &request;  // a request that carries no position (RemoveTeamMember)
  } else {
    if (!api::HasGeoFields(request)) return &request;
    scratch = request;
    OAIPP_RETURN_IF_ERROR(api::ResolveGeoFields(mission.config().geo_origin, &scratch));
    return &scratch;
  }
}

inline void FillEvent(const MissionEventData& e, v1::MissionEvent* out) {
  out->set_sequence(e.sequence);
  *out->mutable_time() = TimeUtil::NanosecondsToTimestamp(absl::ToUnixNanos(e.time));
  if (const auto* m = std::get_if<MissionEventData::MeasurementFused>(&e.event)) {
    auto* f = out->mutable_measurement_fused();
    f->set_mission_time_s(m->mission_time_s);
    f->set_cells_fused(m->cells_fused);
    f->set_trace(m->trace);
    f->set_trace_measurements_fused(m->trace_measurements_fused);
    f->set_uav_id(m->uav_id);
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
    f->set_uav_id(p->uav_id);
    f->set_plan_version(p->plan_version);
  } else if (const auto* r = std::get_if<MissionEventData::MemberRemoved>(&e.event)) {
    out->mutable_team_member_removed()->set_uav_id(r->uav_id);
  } else {
    out->mutable_mission_deleted();
  }
}

}  // namespace service_internal

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
  return api::ToGrpcStatus(Run(method, std::move(body)));
}

template <typename Request, typename Apply>
absl::Status MissionServiceImpl::Mutate(const grpc::ServerContextBase& context,
                                        const Request& request, RecordKind kind, Apply apply) {
  OAIPP_ASSIGN_OR_RETURN(const std::string tenant, TenantOf(context));
  OAIPP_RETURN_IF_ERROR(service_internal::CheckRequestId(request.request_id()));
  OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission, registry_->Get(request.name(), tenant));
  Request resolved;
  OAIPP_ASSIGN_OR_RETURN(const Request* in_metres,
                         service_internal::InLocalMetres(*mission, request, resolved));
  const Request& local = *in_metres;
  const std::string fingerprint = RequestFingerprint(local);
  return registry_->AfterFailedWrite(
      mission,
      apply(mission, local, RequestKey{local.request_id(), fingerprint},
            service_internal::Recorder(registry_->store(), *mission, kind, local, fingerprint)));
}

}  // namespace oaipp::server
