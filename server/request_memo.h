// The first result of each request_id, so that a retried mutation is
// answered, not applied again. Bounded: past `capacity` ids the oldest is
// forgotten. Not thread-safe: the owner guards it with the lock under which
// it checks and applies a mutation, so that the two are one step.
//
//   RequestMemo<MeasurementResult> memo;
//   if (const MeasurementResult* done = memo.Find(request_id)) return *done;
//   ... apply ...
//   memo.Remember(request_id, result);
#pragma once

#include <cstddef>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <utility>

namespace oaipp::server {

template <typename Value>
class RequestMemo {
 public:
  // Request ids remembered per memo by default.
  static constexpr std::size_t kDefaultCapacity = 4096;

  explicit RequestMemo(std::size_t capacity = kDefaultCapacity) : capacity_(capacity) {}

  // The remembered result, or nullptr for an unknown or empty id.
  [[nodiscard]] const Value* Find(const std::string& request_id) const {
    if (request_id.empty()) return nullptr;
    auto it = values_.find(request_id);
    return it == values_.end() ? nullptr : &it->second;
  }

  // Remembers the first result of `request_id` (an empty id is not
  // remembered; a known id keeps its first result). Returns the entry this
  // pushed out past the capacity, if any.
  std::optional<std::pair<std::string, Value>> Remember(const std::string& request_id,
                                                        Value value) {
    if (request_id.empty()) return std::nullopt;
    if (!values_.emplace(request_id, std::move(value)).second) return std::nullopt;
    order_.push_back(request_id);
    if (order_.size() <= capacity_) return std::nullopt;
    auto oldest = values_.extract(order_.front());
    order_.pop_front();
    return std::pair{std::move(oldest.key()), std::move(oldest.mapped())};
  }

  [[nodiscard]] std::size_t size() const { return values_.size(); }

  // Calls f(request_id, value) for every remembered id, oldest first.
  template <typename F>
  void ForEach(F f) const {
    for (const std::string& id : order_) f(id, values_.at(id));
  }

 private:
  std::map<std::string, Value> values_;
  std::deque<std::string> order_;  // oldest first
  std::size_t capacity_;
};

}  // namespace oaipp::server
