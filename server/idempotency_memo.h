// The first answer to each request_id of one mission, so that a retried
// mutation or plan is answered again instead of applied again, and a
// request_id reused for another request is refused. RequestMemo
// (server/request_memo.h) is the bounded map underneath; this adds the
// requests' fingerprints, the refusals and a lock of its own.
//
//   if (auto done = memo.Recall<MeasurementResult>(request)) return *std::move(done);
//   ... apply ...
//   memo.Remember(request, result);
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "core/planning/planner.h"
#include "server/request_memo.h"

namespace oaipp::server {

struct ObstacleResult {
  int obstacle_count = 0;
  std::int64_t esdf_voxels_recomputed = 0;
};

struct MeasurementResult {
  int cells_fused = 0;
  double trace = 0.0;
  std::int64_t measurements_fused = 0;
  std::int64_t trace_measurements_fused = 0;  // the measurements `trace` includes
};

// What RemoveTeamMember answers: the members still in the team, in spec
// order.
struct TeamResult {
  std::vector<std::string> flying_uav_ids;
};

// The first answer to a request_id.
using RequestResult = std::variant<ObstacleResult, MeasurementResult, PlannedPath, TeamResult>;

// A mutation's request_id (empty: none) and the fingerprint of the request
// behind it (empty: not checked). A retry (same id, same fingerprint) gets
// the first answer; the same id with another fingerprint is refused.
struct RequestKey {
  RequestKey(const std::string& id) : request_id(id) {}  // NOLINT: a bare id converts
  RequestKey(const char* id) : request_id(id) {}         // NOLINT
  RequestKey(std::string id, std::string print)
      : request_id(std::move(id)), fingerprint(std::move(print)) {}
  std::string request_id;
  std::string fingerprint;
};

// A remembered answer: the request's fingerprint and its first result.
struct RememberedAnswer {
  std::string fingerprint;
  RequestResult result;
};

// request_id -> first answer (bounded, oldest forgotten first). Its lock is
// a leaf lock of the mission's; the mission holds the lock of the operation
// around Recall and Remember, so that check and apply are one step.
class IdempotencyMemo {
 public:
  // The first result of request.request_id if it was answered before
  // (nullopt for an empty or unknown id); InvalidArgument when the id was
  // first used for a different request (another fingerprint) or for
  // another kind of call. T: ObstacleResult, MeasurementResult,
  // PlannedPath or TeamResult.
  template <typename T>
  [[nodiscard]] std::optional<absl::StatusOr<T>> Recall(const RequestKey& request) const;
  // Remembers the first result of request.request_id (an empty id is not
  // remembered; a known id keeps its first result).
  void Remember(const RequestKey& request, RequestResult result);
  // Recovery: answers read back from a snapshot, oldest first.
  void Restore(std::vector<std::pair<std::string, RememberedAnswer>> answers);
  // What the remembered answers hold in memory (ids, fingerprints, the
  // answers themselves), bytes. It counts against the mission's memory and
  // falls again as newer ids push old ones out.
  [[nodiscard]] std::int64_t bytes() const;
  // Calls f(request_id, answer) for every remembered id, oldest first,
  // under the memo's lock.
  template <typename F>
  void ForEach(F f) const {
    absl::MutexLock lock(&mu_);
    done_.ForEach(f);
  }

 private:
  // Remember and Restore: one entry, with its bytes counted.
  void RememberLocked(const std::string& request_id, RememberedAnswer answer)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  mutable absl::Mutex mu_;
  RequestMemo<RememberedAnswer> done_ ABSL_GUARDED_BY(mu_);
  std::int64_t bytes_ ABSL_GUARDED_BY(mu_) = 0;
};

extern template std::optional<absl::StatusOr<ObstacleResult>>
IdempotencyMemo::Recall<ObstacleResult>(const RequestKey& request) const;
extern template std::optional<absl::StatusOr<MeasurementResult>>
IdempotencyMemo::Recall<MeasurementResult>(const RequestKey& request) const;
extern template std::optional<absl::StatusOr<PlannedPath>> IdempotencyMemo::Recall<PlannedPath>(
    const RequestKey& request) const;

}  // namespace oaipp::server
