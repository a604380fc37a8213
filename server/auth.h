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
#include "grpcpp/security/auth_metadata_processor.h"
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

// The token check before a call's request is read, where gRPC offers one
// (with TLS credentials: an AuthMetadataProcessor runs on the call's
// metadata when it arrives). A call to the mission service with a missing
// or unknown token is refused UNAUTHENTICATED there, so its body is never
// parsed; other services (health, reflection) pass, and so does a call
// whose metadata lacks the method's path. It only decides yes or no: the
// handlers still read the tenant from the call's own metadata (the
// processor's AuthContext belongs to the connection, which calls with
// different tokens may share).
class TokenCheck : public grpc::AuthMetadataProcessor {
 public:
  // `auth` must outlive the check.
  explicit TokenCheck(const Authenticator* auth) : auth_(auth) {}
  // A map lookup and a hash: done on gRPC's own thread.
  [[nodiscard]] bool IsBlocking() const override { return false; }
  grpc::Status Process(const InputMetadata& auth_metadata, grpc::AuthContext* context,
                       OutputMetadata* consumed_auth_metadata,
                       OutputMetadata* response_metadata) override;

 private:
  const Authenticator* const auth_;
};

}  // namespace oaipp::server
