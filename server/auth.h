// Who is calling: bearer tokens mapped to tenants.
//
// The token file holds one tenant per line with the SHA-256 of its token,
// never the token itself, so a copy of the file lets no one in:
//
//   # tenant   sha256 of the token (hex), e.g. printf %s "$TOKEN" | sha256sum
//   alpha      2bb80d537b1da3e38bd30361aa855686bde0eacd7162fef6a25fe97bf527a25b
//
// Clients send "authorization: Bearer <token>" metadata. Without a token
// file every caller is the anonymous tenant "" (a server for one team on a
// trusted network).
#pragma once

#include <map>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "grpcpp/server_context.h"

namespace oaipp::server {

class Authenticator {
 public:
  // Everyone is the anonymous tenant "".
  Authenticator() = default;
  // Reads a token file; InvalidArgument naming the line that is malformed.
  [[nodiscard]] static absl::StatusOr<Authenticator> FromFile(const std::string& path);
  // The same from the file's text.
  [[nodiscard]] static absl::StatusOr<Authenticator> FromText(absl::string_view text);

  // The caller's tenant; Unauthenticated for a missing, malformed or unknown
  // token (the message never repeats the token).
  [[nodiscard]] absl::StatusOr<std::string> TenantOf(const grpc::ServerContextBase& context) const;
  // The same from the authorization header's value (for tests).
  [[nodiscard]] absl::StatusOr<std::string> TenantOfHeader(const std::string* authorization) const;

  [[nodiscard]] bool enabled() const { return !tenant_by_hash_.empty(); }
  [[nodiscard]] std::size_t tenants() const;

  // SHA-256 of `token`, lower-case hex.
  [[nodiscard]] static std::string HashToken(absl::string_view token);

 private:
  std::map<std::string, std::string> tenant_by_hash_;
};

}  // namespace oaipp::server
