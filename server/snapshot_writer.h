// Snapshots written in the background: the missions ask for one when their
// SnapshotPolicy says so, and one thread of the registry takes and stores
// them, one at a time and in the order asked, so that no call waits for a
// snapshot. The registry's side (which missions ask, and how one snapshot
// is taken and stored) is MissionRegistry's, in snapshot_writer.cc.
//
//   SnapshotWriter writer;
//   writer.Start([&](const std::string& id) { TakeSnapshot(id); });
//   writer.Queue("m-000001");
//   writer.Flush();  // written or failed
//   writer.Stop();
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <string>
#include <thread>

#include "absl/synchronization/mutex.h"

namespace oaipp::server {

class SnapshotWriter {
 public:
  SnapshotWriter() = default;
  // Stop().
  ~SnapshotWriter();
  SnapshotWriter(const SnapshotWriter&) = delete;
  SnapshotWriter& operator=(const SnapshotWriter&) = delete;

  // Starts the thread, which calls `write` with each mission id queued.
  // Call at most once.
  void Start(std::function<void(const std::string& mission_id)> write);
  // Whether the thread was started and not yet stopped.
  [[nodiscard]] bool running() const { return thread_.joinable(); }
  // Asks for a snapshot of `mission_id` (ignored once stopping).
  void Queue(const std::string& mission_id);
  // Waits until every snapshot asked for so far is written or has failed.
  void Flush();
  // Counts a snapshot stored (called by `write`).
  void CountWritten();
  // Snapshots stored since start.
  [[nodiscard]] std::int64_t written() const;
  // Finishes the snapshot being written; drops those not begun.
  void Stop();

 private:
  void Loop();

  std::function<void(const std::string& mission_id)> write_;
  mutable absl::Mutex mu_;
  std::deque<std::string> queue_ ABSL_GUARDED_BY(mu_);
  bool busy_ ABSL_GUARDED_BY(mu_) = false;
  bool stopping_ ABSL_GUARDED_BY(mu_) = false;
  std::int64_t written_ ABSL_GUARDED_BY(mu_) = 0;
  std::thread thread_;
};

}  // namespace oaipp::server
