// A mission's log: the sequence numbers its records take in the store, and
// the applied changes kept in memory (the spec is the mission's config; then
// every obstacle change and measurement, Mission::Log()) within a byte limit
// the registry sets from the mission's memory budget.
//
// Mutations and plans take sequence numbers in one order: a record is
// written (PersistFn) with the log's lock held, and its number is taken only
// when the write succeeded. The lock is a leaf: nothing else is locked under
// it but what the write itself needs (the store's own locks).
//
//   OAIPP_RETURN_IF_ERROR(log.CheckRoom(entry_bytes, answers.bytes()));
//   OAIPP_RETURN_IF_ERROR(log.Write([&](std::int64_t sequence) { return store(sequence); }));
//   ... apply the change ...
//   log.Append(change, entry_bytes);
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <variant>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/synchronization/mutex.h"
#include "api/mission_config.h"
#include "core/environment/environment.h"

namespace oaipp::server {

// An applied change, in the log's order.
using LogEntry = std::variant<ObstacleChange, api::MeasurementInput>;

class MissionLog {
 public:
  // Runs `write` (nullptr: nothing to write) with the next sequence number
  // and takes the number when it returns OK; its error is returned and the
  // number stays free.
  [[nodiscard]] absl::Status Write(const std::function<absl::Status(std::int64_t)>& write);
  // The number the next record will take (1 for a new mission).
  [[nodiscard]] std::int64_t next_sequence() const;
  // Recovery: the log goes on after `sequence`.
  void ContinueAfter(std::int64_t sequence);

  // OK when `bytes` more fit beside what the log and `other_bytes` (the
  // remembered answers) hold; else RESOURCE_EXHAUSTED saying so.
  [[nodiscard]] absl::Status CheckRoom(std::int64_t bytes, std::int64_t other_bytes) const;
  // Keeps an applied change of `bytes`.
  void Append(LogEntry entry, std::int64_t bytes);
  [[nodiscard]] std::vector<LogEntry> Entries() const;
  // Read without the lock.
  [[nodiscard]] std::int64_t bytes() const { return bytes_.load(); }
  void set_limit(std::int64_t bytes) { limit_.store(bytes); }

 private:
  mutable absl::Mutex mu_;
  std::int64_t next_sequence_ ABSL_GUARDED_BY(mu_) = 1;
  std::vector<LogEntry> entries_ ABSL_GUARDED_BY(mu_);
  std::atomic<std::int64_t> bytes_{0};
  std::atomic<std::int64_t> limit_{std::numeric_limits<std::int64_t>::max()};
};

}  // namespace oaipp::server
