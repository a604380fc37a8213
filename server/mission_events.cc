// GCC 12 reports -Wmaybe-uninitialized for the fields of an event moved
// out of the queue into a std::optional (TryPop, Pop), although every
// member has an initialiser: its analysis of std::variant loses track of
// which alternative is live. It did not in the larger file these came from,
// where the same code was inlined differently. Only this file is affected.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

#include "server/mission_events.h"

#include <algorithm>
#include <utility>

namespace oaipp::server {

void EventQueue::Push(MissionEventData event) {
  std::function<void()> listener;
  {
    absl::MutexLock lock(&mu_);
    if (closed_) return;
    if (events_.size() >= capacity_) {
      events_.pop_front();
      ++dropped_;
    }
    events_.push_back(std::move(event));
    listener = listener_;
  }
  if (listener) listener();
}

std::optional<MissionEventData> EventQueue::TryPop() {
  absl::MutexLock lock(&mu_);
  if (events_.empty()) return std::nullopt;
  MissionEventData event = std::move(events_.front());
  events_.pop_front();
  return event;
}

void EventQueue::SetListener(std::function<void()> listener) {
  absl::MutexLock lock(&mu_);
  listener_ = std::move(listener);
}

std::optional<MissionEventData> EventQueue::Pop(absl::Time until) {
  absl::MutexLock lock(&mu_);
  auto ready = [this]() ABSL_SHARED_LOCKS_REQUIRED(mu_) { return !events_.empty() || closed_; };
  mu_.AwaitWithDeadline(absl::Condition(&ready), until);
  if (events_.empty()) return std::nullopt;
  MissionEventData event = std::move(events_.front());
  events_.pop_front();
  return event;
}

void EventQueue::Close(absl::Status reason) {
  std::function<void()> listener;
  {
    absl::MutexLock lock(&mu_);
    if (!closed_) close_reason_ = std::move(reason);
    closed_ = true;
    listener = listener_;
  }
  if (listener) listener();
}

bool EventQueue::closed() const {
  absl::MutexLock lock(&mu_);
  return closed_ && events_.empty();
}

absl::Status EventQueue::close_reason() const {
  absl::MutexLock lock(&mu_);
  return close_reason_;
}

std::int64_t EventQueue::dropped() const {
  absl::MutexLock lock(&mu_);
  return dropped_;
}

std::shared_ptr<EventQueue> MissionEvents::Subscribe() {
  auto queue = std::make_shared<EventQueue>(kQueueCapacity);
  absl::MutexLock lock(&mu_);
  watchers_.push_back(queue);
  return queue;
}

void MissionEvents::Unsubscribe(const std::shared_ptr<EventQueue>& queue) {
  absl::MutexLock lock(&mu_);
  std::erase(watchers_, queue);
}

void MissionEvents::Emit(decltype(MissionEventData::event) event) {
  absl::MutexLock lock(&mu_);
  MissionEventData data{++sequence_, absl::Now(), std::move(event)};
  // Streams that ended close their queue; they go here.
  std::erase_if(watchers_, [](const std::shared_ptr<EventQueue>& w) { return w->closed(); });
  for (const auto& w : watchers_) w->Push(data);
}

void MissionEvents::CloseAll(const absl::Status& reason) {
  absl::MutexLock lock(&mu_);
  for (const auto& w : watchers_) w->Close(reason);
  watchers_.clear();
}

void MissionEvents::HandTo(MissionEvents& successor) {
  std::vector<std::shared_ptr<EventQueue>> watchers;
  std::int64_t sequence;
  {
    absl::MutexLock lock(&mu_);
    watchers.swap(watchers_);
    sequence = sequence_;
  }
  absl::MutexLock lock(&successor.mu_);
  successor.sequence_ = std::max(successor.sequence_, sequence);
  for (auto& w : watchers) successor.watchers_.push_back(std::move(w));
}

std::int64_t MissionEvents::last_sequence() const {
  absl::MutexLock lock(&mu_);
  return sequence_;
}

void MissionEvents::MarkDeleted() {
  Emit(MissionEventData::Deleted{});
  CloseAll(absl::OkStatus());
}

}  // namespace oaipp::server
