#include "server/idempotency_memo.h"

#include <cstddef>

#include "absl/strings/str_cat.h"
#include "api/status.h"

namespace oaipp::server {

template <typename T>
std::optional<absl::StatusOr<T>> IdempotencyMemo::Recall(const RequestKey& request) const {
  if (request.request_id.empty()) return std::nullopt;
  absl::MutexLock lock(&mu_);
  const RememberedAnswer* done = done_.Find(request.request_id);
  if (done == nullptr) return std::nullopt;
  if (!request.fingerprint.empty() && !done->fingerprint.empty() &&
      request.fingerprint != done->fingerprint) {
    return absl::StatusOr<T>(absl::InvalidArgumentError(absl::StrCat(
        "request_id: ", api::EchoInput(request.request_id),
        " was first used for a different request; a retry must repeat the request exactly, "
        "a new request needs a new request_id")));
  }
  if (const T* result = std::get_if<T>(&done->result)) return absl::StatusOr<T>(*result);
  return absl::StatusOr<T>(absl::InvalidArgumentError(absl::StrCat(
      "request_id: ", api::EchoInput(request.request_id), " was used by another kind of call")));
}

template std::optional<absl::StatusOr<ObstacleResult>> IdempotencyMemo::Recall<ObstacleResult>(
    const RequestKey& request) const;
template std::optional<absl::StatusOr<MeasurementResult>>
IdempotencyMemo::Recall<MeasurementResult>(const RequestKey& request) const;
template std::optional<absl::StatusOr<PlannedPath>> IdempotencyMemo::Recall<PlannedPath>(
    const RequestKey& request) const;
template std::optional<absl::StatusOr<TeamResult>> IdempotencyMemo::Recall<TeamResult>(
    const RequestKey& request) const;

namespace {

// What one remembered answer holds: its id twice (the memo's map and its
// order), its fingerprint, and the answer (a plan's waypoints, shots and
// trajectory segments).
std::int64_t EntryBytes(const std::string& request_id, const RememberedAnswer& answer) {
  std::size_t bytes = 2 * (sizeof(std::string) + request_id.size()) + answer.fingerprint.size() +
                      sizeof(RememberedAnswer);
  if (const PlannedPath* path = std::get_if<PlannedPath>(&answer.result)) {
    bytes += path->control_waypoints_W.size() * sizeof(Vec3) +
             path->measurement_poses.size() * sizeof(MeasurementPose) +
             path->trajectory.NumSegments() *
                 (2 * sizeof(PolynomialTrajectory::SegmentCoefficients) + sizeof(Vec3));
  }
  if (const TeamResult* team = std::get_if<TeamResult>(&answer.result)) {
    for (const std::string& id : team->flying_uav_ids) bytes += sizeof(std::string) + id.size();
  }
  return static_cast<std::int64_t>(bytes);
}

}  // namespace

void IdempotencyMemo::RememberLocked(const std::string& request_id, RememberedAnswer answer) {
  if (request_id.empty() || done_.Find(request_id) != nullptr) return;
  bytes_ += EntryBytes(request_id, answer);
  if (auto evicted = done_.Remember(request_id, std::move(answer))) {
    bytes_ -= EntryBytes(evicted->first, evicted->second);
  }
}

void IdempotencyMemo::Remember(const RequestKey& request, RequestResult result) {
  absl::MutexLock lock(&mu_);
  RememberLocked(request.request_id, {request.fingerprint, std::move(result)});
}

void IdempotencyMemo::Restore(std::vector<std::pair<std::string, RememberedAnswer>> answers) {
  absl::MutexLock lock(&mu_);
  for (auto& [request_id, answer] : answers) RememberLocked(request_id, std::move(answer));
}

std::int64_t IdempotencyMemo::bytes() const {
  absl::MutexLock lock(&mu_);
  return bytes_;
}

}  // namespace oaipp::server
