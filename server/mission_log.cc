#include "server/mission_log.h"

#include <utility>

#include "absl/strings/str_format.h"

namespace oaipp::server {

absl::Status MissionLog::Write(const std::function<absl::Status(std::int64_t)>& write) {
  absl::MutexLock lock(&mu_);
  if (write) {
    if (absl::Status written = write(next_sequence_); !written.ok()) return written;
  }
  ++next_sequence_;
  return absl::OkStatus();
}

std::int64_t MissionLog::next_sequence() const {
  absl::MutexLock lock(&mu_);
  return next_sequence_;
}

void MissionLog::ContinueAfter(std::int64_t sequence) {
  absl::MutexLock lock(&mu_);
  next_sequence_ = sequence + 1;
}

absl::Status MissionLog::CheckRoom(std::int64_t bytes, std::int64_t other_bytes) const {
  const std::int64_t held = bytes_.load() + other_bytes;
  if (bytes <= limit_.load() - held) return absl::OkStatus();
  return absl::ResourceExhaustedError(absl::StrFormat(
      "name: the mission's log of applied changes holds %.1f MB, all that this server's "
      "per-mission memory limit leaves beside its map and ESDF; continue in a new mission",
      static_cast<double>(held) / 1e6));
}

void MissionLog::Append(LogEntry entry, std::int64_t bytes) {
  absl::MutexLock lock(&mu_);
  entries_.push_back(std::move(entry));
  bytes_ += bytes;
}

std::vector<LogEntry> MissionLog::Entries() const {
  absl::MutexLock lock(&mu_);
  return entries_;
}

}  // namespace oaipp::server
