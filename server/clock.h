// The server's time source for what it decides by elapsed time: take-off
// patience and pacing, and the share of a latency bound a plan may search
// (server/admission.h). The real clock by default; tests pass a ManualClock
// and move it by hand, so that they wait on events, never on the clock.
// gRPC deadlines and log times stay on real time.
//
//   ManualClock clock;
//   ServiceLimits limits{.take_off_patience = absl::Seconds(1), .clock = &clock};
//   ...
//   clock.Advance(absl::Milliseconds(1200));  // the patience is over
#pragma once

#include <atomic>
#include <cstdint>

#include "absl/time/clock.h"
#include "absl/time/time.h"

namespace oaipp::server {

class Clock {
 public:
  virtual ~Clock() = default;
  [[nodiscard]] virtual absl::Time Now() const = 0;
  // absl::Now(); lives as long as the process.
  [[nodiscard]] static const Clock* Real();
};

// A clock that stands still until moved. Safe to read and move from any
// thread.
class ManualClock : public Clock {
 public:
  explicit ManualClock(absl::Time start = absl::UnixEpoch() + absl::Hours(24 * 365 * 50))
      : ns_(absl::ToUnixNanos(start)) {}
  [[nodiscard]] absl::Time Now() const override { return absl::FromUnixNanos(ns_.load()); }
  void Advance(absl::Duration by) { ns_.fetch_add(absl::ToInt64Nanoseconds(by)); }

 private:
  std::atomic<std::int64_t> ns_;
};

inline const Clock* Clock::Real() {
  class RealClock : public Clock {
   public:
    [[nodiscard]] absl::Time Now() const override { return absl::Now(); }
  };
  static const RealClock real;
  return &real;
}

}  // namespace oaipp::server
