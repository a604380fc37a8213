// PlanPath: one reactor per call (MissionServiceImpl::PlanReactor).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <optional>
#include <string>

#include "absl/synchronization/mutex.h"
#include "api/metadata.h"
#include "api/plan.h"
#include "server/service.h"
#include "server/service_internal.h"

namespace oaipp::server {

using api::PlannedPathToProto;
using api::ToGrpcStatus;
using api::UavStateFromProto;
using service_internal::AfterWrite;
using service_internal::AppendStatus;
using service_internal::PlanningDeadline;

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
        arrived_(service->limits_.clock->Now()) {
    service_->TagReplica(context_);
    // A plan that was queued is counted (metrics, log) when it ends.
    const absl::Status status = service_->Run(
        "PlanPath", [&] { return Start(); }, /*record_ok=*/false);
    if (!status.ok()) {
      if (take_off_) service_->admission_.TakeOffEnded(absl::ZeroDuration());
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
    OAIPP_RETURN_IF_ERROR(service_internal::CheckRequestId(request_->request_id()));
    OAIPP_ASSIGN_OR_RETURN(mission_, service_->registry_->Get(request_->name(), tenant_));
    if (!request_->has_state()) return absl::InvalidArgumentError("state: required");
    v1::UavState state = request_->state();
    OAIPP_RETURN_IF_ERROR(api::ResolveGeoFields(mission_->config().geo_origin, &state, "state"));
    OAIPP_ASSIGN_OR_RETURN(state_, UavStateFromProto(state, "state"));
    if (request_->has_next_shot_mission_s()) next_shot_ = request_->next_shot_mission_s();
    call_.deadline = PlanningDeadline(context_);
    OAIPP_RETURN_IF_ERROR(mission_->CheckPlanningUav(request_->uav_id()));
    call_.uav_id = request_->uav_id();
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
                                                           .epoch = mission_->lease().epoch()}));
      };
    }
    // A UAV at rest at mission time 0 has not flown: it can wait on the
    // ground for its first path.
    if (service_->limits_.max_take_off_plans > 0 && state_.mission_time_s == 0.0 &&
        state_.velocity_W_m_s.isZero() && state_.accel_W_m_s2.isZero()) {
      std::optional<Admission::TakeOffRefusal> refused =
          service_->admission_.AdmitTakeOff(mission_->lease().grounded_since());
      if (refused.has_value()) {
        mission_->lease().NoteTakeOffRefused(service_->limits_.clock->Now());
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
    OAIPP_RETURN_IF_ERROR(service_->admission_.AcquirePlan(tenant_));
    holds_plan_ = true;
    absl::MutexLock lock(&mu_);
    absl::StatusOr<PlanningPool::Handle> job =
        service_->planners_->Submit(mission_->id(), [this] { Plan(); });
    if (!job.ok()) {
      service_->admission_.ReleasePlan(tenant_);
      holds_plan_ = false;
      return job.status();
    }
    job_ = *std::move(job);
    service_->admission_.NotePlanQueued(arrived_);
    return absl::OkStatus();
  }

  // On a planning thread.
  void Plan() {
    const absl::Status status = service_->Run("PlanPath", [&]() -> absl::Status {
      if (call_.cancelled()) return absl::CancelledError("PlanPath: cancelled by the client");
      call_.queued = service_->limits_.clock->Now() - arrived_;
      call_.search_fraction = service_->admission_.SearchFraction(call_.queued);
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
            std::max(std::min(bound - call_.queued, service_->admission_.FairShare()), bound / 100);
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
    if (holds_plan_) service_->admission_.ReleasePlan(tenant_);
    if (take_off_) {
      service_->admission_.TakeOffEnded(planned_);
      if (status.ok()) mission_->lease().NoteTookOff();  // a failed one waits on
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

}  // namespace oaipp::server
