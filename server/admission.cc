#include "server/admission.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"

namespace oaipp::server {

absl::Status Admission::AcquireStream(const std::string& client) {
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

void Admission::ReleaseStream(const std::string& client) {
  absl::MutexLock lock(&quota_mu_);
  --streams_;
  if (--streams_by_client_[client] <= 0) streams_by_client_.erase(client);
}

absl::Status Admission::AcquirePlan(const std::string& tenant) {
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

void Admission::ReleasePlan(const std::string& tenant) {
  absl::MutexLock lock(&quota_mu_);
  if (--plans_by_tenant_[tenant] <= 0) plans_by_tenant_.erase(tenant);
}

bool Admission::Overloaded() const {
  if (planners_->waiting() >= planners_->queue_capacity() &&
      planners_->running() >= planners_->threads()) {
    return true;
  }
  absl::MutexLock lock(&quota_mu_);
  return streams_ >= limits_.max_streams;
}

double Admission::SearchFraction(absl::Duration queued) const {
  if (limits_.shed_after_wait > absl::ZeroDuration() && queued >= limits_.shed_after_wait) {
    return limits_.min_search_fraction;
  }
  if (!(limits_.shed_above > 0.0)) return 1.0;
  const double waiting = planners_->waiting();
  const double allowed = limits_.shed_above * planners_->threads();
  if (waiting <= allowed) return 1.0;
  return std::clamp(allowed / waiting, limits_.min_search_fraction, 1.0);
}

void Admission::NotePlanQueued(absl::Time arrived) {
  absl::MutexLock lock(&quota_mu_);
  newest_plan_ = std::max(newest_plan_, arrived);
}

std::optional<Admission::TakeOffRefusal> Admission::AdmitTakeOff(
    std::optional<absl::Time> grounded_since) {
  // UAVs in the air hover while they wait for a path: a take-off also
  // waits while as many plans queue as there are planning threads, unless
  // it has waited the patience since its first refusal.
  const int waiting = planners_->waiting();
  const int threads = planners_->threads();
  const absl::Time now = limits_.clock->Now();
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

void Admission::TakeOffEnded(absl::Duration planned) {
  absl::MutexLock lock(&quota_mu_);
  --take_offs_;
  if (planned > absl::ZeroDuration()) take_off_cost_ = 0.8 * take_off_cost_ + 0.2 * planned;
}

// Plans are taken up in about arrival order (one plan per mission at a
// time), so the newest has about the latest bound: the plan starting now
// and the `behind` queued after it share the planning threads until then.
// Plans already running on other threads are not counted, so a queue that
// forms behind them can end somewhat past the bound.
absl::Duration Admission::FairShare() const {
  const absl::Duration bound = limits_.plan_latency;
  const int behind = planners_->waiting();
  if (bound <= absl::ZeroDuration() || behind == 0) return absl::InfiniteDuration();
  absl::Time newest;
  {
    absl::MutexLock lock(&quota_mu_);
    newest = newest_plan_;
  }
  return (newest + bound - limits_.clock->Now()) * planners_->threads() / (behind + 1);
}

int Admission::open_streams() const {
  absl::MutexLock lock(&quota_mu_);
  return streams_;
}

}  // namespace oaipp::server
