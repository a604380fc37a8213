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
#include "server/auth.h"
#include "server/metrics.h"
#include "server/planning_pool.h"
#include "server/registry.h"

namespace oaipp::server {

struct ServiceLimits {
  // Open WatchMission streams in all, and per client (per tenant with
  // tokens; per connection without). Valid: >= 1.
  int max_streams = 256;
  int max_streams_per_client = 16;
  // Plans one tenant may have queued or running at once; 0: only the
  // planning pool's queue applies.
  int max_plans_per_tenant = 0;
  // The longest one plan may hold a planner: a plan without a
  // planning_budget_s, or with a longer one, gets this budget (and returns
  // the best path found by then). Valid: > 0.
  absl::Duration max_planning = absl::Seconds(60);
  // Overload: when more than shed_above x (planning threads) plans wait, a
  // plan that starts runs only that share of its search
  // (PlanningContext::search_fraction = shed_above x threads / waiting, at
  // least min_search_fraction), so the queue drains faster and waiting
  // callers get a path sooner; the response's stats.search_fraction says so.
  // 0: never shed (every plan runs its whole search).
  double shed_above = 0.0;
  double min_search_fraction = 0.1;
  // Overload: a plan's search ends at most this long after its call
  // arrived, the wait for a planner included, so a burst of plans cannot
  // keep callers waiting for seconds. Plans queued together share the time
  // left until the newest one's bound: one that starts with k plans queued
  // behind it searches at most threads x (time left) / (k + 1), so the
  // queue is answered at about the bound instead of the first plans taking
  // all of it and the last ones none (plans already running on other
  // threads are not counted). A plan with (almost) nothing left still plans
  // for a hundredth of the bound and returns its best path by then
  // (stop_reason "deadline"; UNAVAILABLE if it found none, since only a
  // retry helps); stats.queued_s says how long it waited. Zero: no bound.
  // shed_above is then best left at 0: the bound already shrinks searches
  // as much as the queue needs, and no more.
  absl::Duration plan_latency = absl::ZeroDuration();
  // Take-off pacing: at most this many take-off plans (asked for at mission
  // time 0 from rest, by a UAV that has not flown yet and can wait on the
  // ground) queued or running at once, and none admitted while as many
  // plans wait as there are planning threads (UAVs in the air hover while
  // they wait). Another is refused at once with RESOURCE_EXHAUSTED and a
  // retry delay (trailing metadata api::kRetryAfterHeader): the refused
  // callers are told to come back one after another, a take-off plan's
  // recent planning time over the threads apart. A fleet that takes off
  // together then leaves over several seconds with whole first plans,
  // instead of every first plan searching a share of the bound. Replans
  // are never paced, but a repeated take-off request (same request_id) is
  // paced like a new one before its stored answer is looked up. 0: no
  // pacing.
  int max_take_off_plans = 0;
  // Take-off pacing's patience: a UAV whose first take-off request was
  // refused this long ago is no longer held back by the queue rule (as
  // many plans waiting as threads; the max_take_off_plans limit still
  // holds), so that under a steady replan load the last of a fleet do not
  // stay on the ground indefinitely. InfiniteDuration: the rule always
  // holds.
  absl::Duration take_off_patience = absl::Seconds(5);
  // Sent back on every call as the initial-metadata header
  // api::kReplicaHeader (which server answered: for operators and tests of
  // a cluster); empty: not sent.
  std::string replica_id = {};
};

using MissionServiceBase = v1::MissionService::WithCallbackMethod_PlanPath<
    v1::MissionService::WithCallbackMethod_WatchMission<v1::MissionService::Service>>;

class MissionServiceImpl final : public MissionServiceBase {
 public:
  // Pointers must outlive the service; metrics and auth may be null (no
  // metrics; everyone is the anonymous tenant).
  MissionServiceImpl(MissionRegistry* registry, PlanningPool* planners, Metrics* metrics,
                     const Authenticator* auth = nullptr, ServiceLimits limits = {})
      : registry_(registry), planners_(planners), metrics_(metrics), auth_(auth), limits_(limits) {}

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

  // True while new plans or streams would be refused: every planner busy
  // and the queue full, or the stream limit reached (health reports it).
  [[nodiscard]] bool Overloaded() const;
  // The share of its search a plan starting now runs (ServiceLimits::shed_above).
  [[nodiscard]] double SearchFraction() const;
  // With a plan latency bound: how long a plan starting now may search so
  // that it and the plans queued behind it all end by the newest one's
  // bound (ServiceLimits::plan_latency).
  [[nodiscard]] absl::Duration FairShare() const;
  // A plan that arrived at `arrived` was queued (FairShare's newest plan).
  void NotePlanQueued(absl::Time arrived);
  // Take-off pacing (ServiceLimits::max_take_off_plans): nullopt, and the
  // plan is counted, when a take-off plan may be queued now; else how long
  // its caller should wait before asking again (at most kMaxTakeOffDelay)
  // and why.
  struct TakeOffRefusal {
    absl::Duration retry_after;
    std::string reason;
  };
  static constexpr absl::Duration kMaxTakeOffDelay = absl::Seconds(10);
  // `grounded_since`: when the asking mission's take-off was first refused
  // (nullopt: it was not).
  [[nodiscard]] std::optional<TakeOffRefusal> AdmitTakeOff(
      std::optional<absl::Time> grounded_since);
  // A take-off plan admitted by AdmitTakeOff ended, after planning for
  // `planned` (zero when it did not run).
  void TakeOffEnded(absl::Duration planned);
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

  // Stream and plan quotas: Acquire* refuses with ResourceExhausted.
  absl::Status AcquireStream(const std::string& client);
  void ReleaseStream(const std::string& client);
  absl::Status AcquirePlan(const std::string& tenant);
  void ReleasePlan(const std::string& tenant);

  MissionRegistry* registry_;
  PlanningPool* planners_;
  Metrics* metrics_;
  const Authenticator* auth_;
  const ServiceLimits limits_;

  mutable absl::Mutex quota_mu_;
  int streams_ ABSL_GUARDED_BY(quota_mu_) = 0;
  std::map<std::string, int> streams_by_client_ ABSL_GUARDED_BY(quota_mu_);
  std::map<std::string, int> plans_by_tenant_ ABSL_GUARDED_BY(quota_mu_);
  // When the newest queued plan arrived (NotePlanQueued).
  absl::Time newest_plan_ ABSL_GUARDED_BY(quota_mu_) = absl::InfinitePast();
  // Take-off pacing: admitted take-off plans not yet ended, the time the
  // last refused caller was told to come back, and the running mean of a
  // take-off plan's planning time (0.1 s until one has run).
  int take_offs_ ABSL_GUARDED_BY(quota_mu_) = 0;
  absl::Time take_off_slot_ ABSL_GUARDED_BY(quota_mu_) = absl::InfinitePast();
  absl::Duration take_off_cost_ ABSL_GUARDED_BY(quota_mu_) = absl::Milliseconds(100);
  // Applies the covariance downdates AddMeasurement leaves pending
  // (Mission::SettleMap) after it has answered, one at a time, at the
  // process's priority; a full queue is harmless (readers settle). Last, so
  // that it is destroyed first, running what it holds.
  PlanningPool settlers_{/*threads=*/1, /*queue=*/4096};
};

}  // namespace oaipp::server
