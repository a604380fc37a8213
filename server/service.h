// The oaipp.v1.MissionService implementation over a MissionRegistry.
//
// Thin: each RPC converts its request (api/), calls the mission,
// and converts the result back; errors become gRPC status codes with the
// offending field named. Testable in-process without a network:
//
//   MissionRegistry registry({});
//   PlanningGate gate(2, 8);
//   MissionServiceImpl service(&registry, &gate, /*metrics=*/nullptr);
//   grpc::ServerBuilder builder;
//   builder.RegisterService(&service);
//   auto server = builder.BuildAndStart();
//   auto channel = server->InProcessChannel({});
#pragma once

#include <memory>

#include "oaipp/v1/mission_service.grpc.pb.h"
#include "server/metrics.h"
#include "server/planning_gate.h"
#include "server/registry.h"

namespace oaipp::server {

class MissionServiceImpl final : public v1::MissionService::Service {
 public:
  // Pointers must outlive the service; metrics may be null.
  MissionServiceImpl(MissionRegistry* registry, PlanningGate* gate, Metrics* metrics)
      : registry_(registry), gate_(gate), metrics_(metrics) {}

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
  grpc::Status PlanPath(grpc::ServerContext* context, const v1::PlanPathRequest* request,
                        v1::PlanPathResponse* response) override;
  grpc::Status GetMap(grpc::ServerContext* context, const v1::GetMapRequest* request,
                      v1::GetMapResponse* response) override;
  grpc::Status WatchMission(grpc::ServerContext* context, const v1::WatchMissionRequest* request,
                            grpc::ServerWriter<v1::MissionEvent>* writer) override;

 private:
  // Runs one RPC body, recording its latency and status in the metrics.
  template <typename Body>
  grpc::Status Call(const char* method, Body body);

  MissionRegistry* registry_;
  PlanningGate* gate_;
  Metrics* metrics_;
};

}  // namespace oaipp::server
