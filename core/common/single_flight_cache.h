// A small cache of values that are expensive to compute and shared once
// made (the prior covariance of a kind of field, the world of a site): at
// most `capacity` values by key, the least recently used dropped beyond
// that; concurrent first requests for one key compute it once while the
// others wait; a failed computation is not remembered. Thread-safe. Keys
// are compared with ==, in a short list (capacities are a handful).
//
//   SingleFlightCache<std::string, Environment> worlds(/*capacity=*/4);
//   OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<const Environment> world,
//                          worlds.Get(key, [&] { return config.MakeEnvironment(); }));
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <functional>
#include <future>
#include <memory>
#include <utility>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"

namespace oaipp {

template <typename Key, typename Value>
class SingleFlightCache {
 public:
  using Result = absl::StatusOr<std::shared_ptr<const Value>>;

  // capacity >= 1 (smaller values are raised to 1).
  explicit SingleFlightCache(int capacity) : capacity_(std::max(capacity, 1)) {}

  // The value for `key`: made by `compute` on the first request for it (the
  // key must say everything compute depends on), shared after that. Errors
  // are compute's, and not remembered.
  [[nodiscard]] Result Get(const Key& key, const std::function<absl::StatusOr<Value>()>& compute) {
    std::shared_future<Result> value;
    std::promise<Result> promise;
    bool computing = false;
    std::uint64_t inserted = 0;
    {
      absl::MutexLock lock(&mu_);
      auto it = std::find_if(entries_.begin(), entries_.end(),
                             [&](const Entry& e) { return e.key == key; });
      if (it != entries_.end()) {
        it->last_used = ++clock_;
        value = it->value;
      } else {
        if (static_cast<int>(entries_.size()) >= capacity_) {
          // Waiters on a dropped value hold their own copy of its future.
          entries_.erase(std::min_element(
              entries_.begin(), entries_.end(),
              [](const Entry& a, const Entry& b) { return a.last_used < b.last_used; }));
        }
        value = promise.get_future().share();
        inserted = ++clock_;
        entries_.push_back({key, value, inserted, inserted});
        ++computations_;
        computing = true;
      }
    }
    if (computing) {
      absl::StatusOr<Value> made = compute();
      if (made.ok()) {
        promise.set_value(std::make_shared<const Value>(*std::move(made)));
      } else {
        promise.set_value(made.status());
        absl::MutexLock lock(&mu_);
        std::erase_if(entries_, [&](const Entry& e) { return e.inserted == inserted; });
      }
    }
    return value.get();
  }

  // True when `match` holds for a value made and held here (values still
  // being computed are skipped).
  [[nodiscard]] bool AnyHeld(const std::function<bool(const Value&)>& match) const {
    absl::MutexLock lock(&mu_);
    for (const Entry& e : entries_) {
      if (e.value.wait_for(std::chrono::seconds(0)) != std::future_status::ready) continue;
      const Result& held = e.value.get();
      if (held.ok() && match(**held)) return true;
    }
    return false;
  }

  // How many values were computed (misses), and how many are held.
  [[nodiscard]] std::int64_t computations() const {
    absl::MutexLock lock(&mu_);
    return computations_;
  }
  [[nodiscard]] int size() const {
    absl::MutexLock lock(&mu_);
    return static_cast<int>(entries_.size());
  }

 private:
  struct Entry {
    Key key;
    std::shared_future<Result> value;
    std::uint64_t inserted = 0;  // clock at insertion: tells entries of one key apart
    std::uint64_t last_used = 0;
  };
  const int capacity_;
  mutable absl::Mutex mu_;
  std::vector<Entry> entries_ ABSL_GUARDED_BY(mu_);
  std::uint64_t clock_ ABSL_GUARDED_BY(mu_) = 0;
  std::int64_t computations_ ABSL_GUARDED_BY(mu_) = 0;
};

}  // namespace oaipp
