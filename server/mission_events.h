// What happened to a mission, for the streams that watch it (WatchMission,
// the live view): the events in order, a bounded queue per watcher, and the
// hub that numbers each event and hands it to every watcher's queue.
//
//   MissionEvents events;
//   std::shared_ptr<EventQueue> queue = events.Subscribe();
//   events.Emit(MissionEventData::ObstaclesChanged{3});
//   std::optional<MissionEventData> event = queue->Pop(absl::Now() + absl::Seconds(1));
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <variant>
#include <vector>

#include "absl/status/status.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "core/common/geometry.h"

namespace oaipp::server {

// What happened to a mission, in order (for WatchMission).
struct MissionEventData {
  std::int64_t sequence = 0;
  absl::Time time;
  struct MeasurementFused {
    double mission_time_s = 0.0;
    int cells_fused = 0;
    double trace = 0.0;
    Vec3 camera_position_W = Vec3::Zero();
    std::vector<int> detected_cells;            // labelled >= kDetectedLabel
    std::int64_t trace_measurements_fused = 0;  // the measurements `trace` includes
    std::string uav_id = {};                    // who took it ("" without a team)
  };
  struct ObstaclesChanged {
    int obstacle_count = 0;
  };
  struct PathPlanned {
    double mission_time_s = 0.0;
    double duration_s = 0.0;
    double objective = 0.0;
    std::vector<Vec3> control_waypoints_W;
    Vec3 start_W = Vec3::Zero();
    std::string uav_id = {};  // whose path ("" without a team)
    std::int64_t plan_version = 0;
  };
  struct Deleted {};
  struct MemberRemoved {
    std::string uav_id;
  };
  std::variant<MeasurementFused, ObstaclesChanged, PathPlanned, Deleted, MemberRemoved> event;
};

// A bounded queue of events for one watcher.
class EventQueue {
 public:
  explicit EventQueue(std::size_t capacity) : capacity_(capacity) {}
  // Adds an event; when full the oldest is dropped and counted.
  void Push(MissionEventData event);
  // Waits until an event is there or `until`; nullopt on timeout.
  std::optional<MissionEventData> Pop(absl::Time until);
  // The oldest event, without waiting; nullopt when there is none.
  std::optional<MissionEventData> TryPop();
  // Called after every Push and Close, outside the queue's lock (a stream
  // is woken this way instead of a thread waiting in Pop).
  void SetListener(std::function<void()> listener);
  // No more events; the watcher's stream ends with `reason` (OK: the
  // mission was deleted and the watcher was told so by an event).
  void Close(absl::Status reason = absl::OkStatus());
  [[nodiscard]] bool closed() const;
  [[nodiscard]] absl::Status close_reason() const;
  [[nodiscard]] std::int64_t dropped() const;

 private:
  mutable absl::Mutex mu_;
  std::deque<MissionEventData> events_ ABSL_GUARDED_BY(mu_);
  bool closed_ ABSL_GUARDED_BY(mu_) = false;
  absl::Status close_reason_ ABSL_GUARDED_BY(mu_);
  std::int64_t dropped_ ABSL_GUARDED_BY(mu_) = 0;
  std::function<void()> listener_ ABSL_GUARDED_BY(mu_);
  std::size_t capacity_;
};

// One mission's watchers and the numbering of its events. A mission emits
// after a change is in place, outside its other locks: the hub's lock is a
// leaf of the mission's, and only the queues' own locks are taken inside it.
class MissionEvents {
 public:
  // Events a watcher's queue holds before the oldest are dropped.
  static constexpr std::size_t kQueueCapacity = 1024;

  // Watchers get every event after they subscribe.
  [[nodiscard]] std::shared_ptr<EventQueue> Subscribe();
  void Unsubscribe(const std::shared_ptr<EventQueue>& queue);
  // Numbers `event` (the next sequence), stamps it with the time and hands
  // it to every watcher whose stream has not ended.
  void Emit(decltype(MissionEventData::event) event);
  // Closes every watcher's queue with `reason` and forgets the watchers:
  // their streams end, and they watch again where the mission is now (a
  // mission another server of a cluster took over).
  void CloseAll(const absl::Status& reason);
  // Tells watchers the mission is gone and closes their queues.
  void MarkDeleted();
  // Moves the watchers to `successor`, whose numbering goes on from at
  // least this hub's last event.
  void HandTo(MissionEvents& successor);
  // The number of the last event (0 before the first).
  [[nodiscard]] std::int64_t last_sequence() const;
  // Watchers subscribed now.
  [[nodiscard]] int watchers() const {
    absl::MutexLock lock(&mu_);
    return static_cast<int>(watchers_.size());
  }

 private:
  mutable absl::Mutex mu_;
  std::int64_t sequence_ ABSL_GUARDED_BY(mu_) = 0;
  std::vector<std::shared_ptr<EventQueue>> watchers_ ABSL_GUARDED_BY(mu_);
};

}  // namespace oaipp::server
