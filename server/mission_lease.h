// A mission's standing on this server, kept beside it for the registry and
// the service and read without any of the mission's locks (atomics only):
// the store's ownership epoch this copy was read at, when this server last
// renewed its lease on it (a shared store), and since when its take-off
// has been refused (take-off pacing). In memory only: a restart, a reload or
// another server taking the mission over starts them afresh.
//
//   mission->lease().set_epoch(claimed.epoch);
//   if (now - mission->lease().renewed() > lease / 4) mission->lease().set_renewed(now);
#pragma once

#include <atomic>
#include <cstdint>
#include <limits>
#include <optional>

#include "absl/time/time.h"

namespace oaipp::server {

class MissionLease {
 public:
  // The store's ownership epoch this copy was read at (MissionStore::Claim);
  // every record it writes states it.
  [[nodiscard]] std::int64_t epoch() const { return epoch_.load(); }
  void set_epoch(std::int64_t epoch) { epoch_.store(epoch); }

  // Shared store: when this server last renewed its lease on the mission
  // (the infinite past until then).
  [[nodiscard]] absl::Time renewed() const { return absl::FromUnixMicros(renewed_us_.load()); }
  void set_renewed(absl::Time at) { renewed_us_.store(absl::ToUnixMicros(at)); }

  // Take-off pacing (ServiceLimits::take_off_patience): when this mission's
  // take-off was first refused; nullopt if it was not, or a take-off plan
  // has since been answered OK. (A refusal racing an admitted take-off of
  // the same mission may leave it set; that mission's next take-off then
  // skips the queue rule.)
  [[nodiscard]] std::optional<absl::Time> grounded_since() const {
    const std::int64_t ns = grounded_since_ns_.load();
    return ns == kNotGrounded ? std::nullopt : std::optional(absl::FromUnixNanos(ns));
  }
  void NoteTakeOffRefused(absl::Time now) {
    std::int64_t expected = kNotGrounded;
    grounded_since_ns_.compare_exchange_strong(expected, absl::ToUnixNanos(now));
  }
  void NoteTookOff() { grounded_since_ns_.store(kNotGrounded); }

 private:
  static constexpr std::int64_t kNotGrounded = std::numeric_limits<std::int64_t>::min();
  std::atomic<std::int64_t> epoch_{1};
  std::atomic<std::int64_t> renewed_us_{std::numeric_limits<std::int64_t>::min()};
  std::atomic<std::int64_t> grounded_since_ns_{kNotGrounded};
};

}  // namespace oaipp::server
