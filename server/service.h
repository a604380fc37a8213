// The oaipp.v1.MissionService implementation over a MissionRegistry.
//
// Thin: each RPC converts its request (api/), calls the mission,
// and converts the result back; errors become gRPC status codes with the
// offending field named. Testable in-process without a network:
//
//   MissionRegistry registry({});
//   PlanningPool planners(2, 8);
//   MissionServiceImpl service(&registry, &planners, /*metrics=*/nullptr);
//   grpc::ServerBuilder builder;
//   builder.RegisterService(&service);
//   auto server = builder.BuildAndStart();
//   auto channel = server->InProcessChannel({});
//
// PlanPath and WatchMission use gRPC's callback API: a queued plan is a job
// in the PlanningPool and an open stream is a reactor woken by its events,
// so neither holds one of the server's threads while it waits. The quick
// calls run on the synchronous thread pool.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>

#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "oaipp/v1/mission_service.grpc.pb.h"
#include "server/admission.h"
#include "server/auth.h"
#include "server/metrics.h"
#include "server/planning_pool.h"
#include "server/registry.h"
#include "server/service_limits.h"

namespace oaipp::server {

using MissionServiceBase = v1::MissionService::WithCallbackMethod_PlanPath<
    v1::MissionService::WithCallbackMethod_WatchMission<v1::MissionService::Service>>;

class MissionServiceImpl final : public MissionServiceBase {
 public:
  // Pointers must outlive the service; metrics and auth may be null (no
  // metrics; everyone is the anonymous tenant).
  MissionServiceImpl(MissionRegistry* registry, PlanningPool* planners, Metrics* metrics,
                     const Authenticator* auth = nullptr, ServiceLimits limits = {})
      : registry_(registry),
        planners_(planners),
        metrics_(metrics),
        auth_(auth),
        limits_(limits),
        admission_(limits, planners) {}

  grpc::Status CreateMission(grpc::ServerContext* context, const v1::CreateMissionRequest* request,
                             v1::Mission* response) override;
  grpc::Status GetMission(grpc::ServerContext* context, const v1::GetMissionRequest* request,
                          v1::Mission* response) override;
  grpc::Status ListMissions(grpc::ServerContext* context, const v1::ListMissionsRequest* request,
                            v1::ListMissionsResponse* response) override;
  grpc::Status DeleteMission(grpc::ServerContext* context, const v1::DeleteMissionRequest* request,
                             v1::DeleteMissionResponse* response) override;
  grpc::Status UpdateObstacles(grpc::ServerContext* context,
                               const v1::UpdateObstaclesRequest* request,
                               v1::UpdateObstaclesResponse* response) override;
  grpc::Status AddMeasurement(grpc::ServerContext* context,
                              const v1::AddMeasurementRequest* request,
                              v1::AddMeasurementResponse* response) override;
  grpc::Status GetMap(grpc::ServerContext* context, const v1::GetMapRequest* request,
                      v1::GetMapResponse* response) override;
  grpc::ServerUnaryReactor* PlanPath(grpc::CallbackServerContext* context,
                                     const v1::PlanPathRequest* request,
                                     v1::PlanPathResponse* response) override;
  grpc::ServerWriteReactor<v1::MissionEvent>* WatchMission(
      grpc::CallbackServerContext* context, const v1::WatchMissionRequest* request) override;
  grpc::Status ExportPath(grpc::ServerContext* context, const v1::ExportPathRequest* request,
                          v1::ExportPathResponse* response) override;
  grpc::Status RemoveTeamMember(grpc::ServerContext* context,
                                const v1::RemoveTeamMemberRequest* request,
                                v1::RemoveTeamMemberResponse* response) override;

  // True while new plans or streams would be refused: every planner busy
  // and the queue full, or the stream limit reached (health reports it).
  [[nodiscard]] bool Overloaded() const;
  // WatchMission streams open now.
  [[nodiscard]] int open_streams() const;

 private:
  class PlanReactor;
  class WatchReactor;

  // Runs one RPC body, recording its latency and status in the metrics;
  // an error's message is made safe to repeat (api::SafeMessage).
  // record_ok: false for the first part of a call that goes on elsewhere
  // (only its errors are recorded then).
  template <typename Body>
  absl::Status Run(const char* method, Body body, bool record_ok = true);
  template <typename Body>
  grpc::Status Call(grpc::ServerContextBase* context, const char* method, Body body);
  // Adds api::kReplicaHeader to the call's answer (before anything is sent).
  void TagReplica(grpc::ServerContextBase* context) const;
  [[nodiscard]] absl::StatusOr<std::string> TenantOf(const grpc::ServerContextBase& context) const;

  // The path every write to an existing mission takes
  // (service_internal.h): the caller's tenant, the mission the request
  // names, the request's geodetic fields in the mission's metres (before
  // anything sees or stores it), its fingerprint, then `apply` with the
  // idempotency key and the writer of its record; after a failed write the
  // registry says what the caller sees (AfterFailedWrite).
  //   apply(const std::shared_ptr<Mission>&, const Request& local,
  //         const RequestKey&, const PersistFn&) -> absl::Status
  template <typename Request, typename Apply>
  absl::Status Mutate(const grpc::ServerContextBase& context, const Request& request,
                      RecordKind kind, Apply apply);

  MissionRegistry* registry_;
  PlanningPool* planners_;
  Metrics* metrics_;
  const Authenticator* auth_;
  const ServiceLimits limits_;
  // Quotas, shedding, the latency bound and take-off pacing.
  Admission admission_;
  // Applies the covariance downdates AddMeasurement leaves pending
  // (Mission::SettleMap) after it has answered, one at a time, at the
  // process's priority; a full queue is harmless (readers settle). Last, so
  // that it is destroyed first, running what it holds.
  PlanningPool settlers_{/*threads=*/1, /*queue=*/4096};
};

}  // namespace oaipp::server
