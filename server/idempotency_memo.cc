#include "server/idempotency_memo.h"

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

void IdempotencyMemo::Remember(const RequestKey& request, RequestResult result) {
  absl::MutexLock lock(&mu_);
  done_.Remember(request.request_id, {request.fingerprint, std::move(result)});
}

void IdempotencyMemo::Restore(std::vector<std::pair<std::string, RememberedAnswer>> answers) {
  absl::MutexLock lock(&mu_);
  for (auto& [request_id, answer] : answers) done_.Remember(request_id, std::move(answer));
}

}  // namespace oaipp::server
