// WatchMission: one reactor per stream (MissionServiceImpl::WatchReactor).
#include <memory>
#include <optional>
#include <string>
#include <variant>

#include "absl/synchronization/mutex.h"
#include "server/service.h"
#include "server/service_internal.h"

namespace oaipp::server {

using api::ToGrpcStatus;
using service_internal::FillEvent;

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
      OAIPP_RETURN_IF_ERROR(service_->admission_.AcquireStream(client_));
      holds_stream_ = true;
      return absl::OkStatus();
    });
    if (!opened.ok()) {
      Finish(ToGrpcStatus(opened));
      return;
    }
    link_ = std::make_shared<Link>();
    link_->reactor = this;
    queue_ = mission_->events().Subscribe();
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
      mission_->events().Unsubscribe(queue_);
    }
    if (holds_stream_) service_->admission_.ReleaseStream(client_);
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
