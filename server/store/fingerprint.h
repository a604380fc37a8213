// A request's fingerprint: FNV-1a (64 bit, hex) of its serialized bytes with
// request_id cleared, so that a retry (same payload) and a reuse of the id
// for another payload can be told apart, also across restarts.
#pragma once

#include <cstdint>
#include <string>

#include "absl/strings/str_format.h"
#include "absl/strings/string_view.h"

namespace oaipp::server {

[[nodiscard]] inline std::string FingerprintBytes(absl::string_view bytes) {
  std::uint64_t hash = 0xcbf29ce484222325ULL;
  for (unsigned char c : bytes) {
    hash ^= c;
    hash *= 0x100000001b3ULL;
  }
  return absl::StrFormat("%016x", hash);
}

// Request: a generated message with a request_id field.
template <typename Request>
[[nodiscard]] std::string RequestFingerprint(const Request& request) {
  Request copy = request;
  copy.clear_request_id();
  std::string bytes;
  copy.SerializeToString(&bytes);
  return FingerprintBytes(bytes);
}

}  // namespace oaipp::server
