#include "server/auth.h"

#include <openssl/evp.h>

#include <fstream>
#include <set>
#include <sstream>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace oaipp::server {
namespace {

bool ValidTenant(absl::string_view tenant) {
  if (tenant.empty() || tenant.size() > 63) return false;
  for (char c : tenant) {
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-')) return false;
  }
  return true;
}

bool ValidHash(absl::string_view hash) {
  if (hash.size() != 64) return false;
  for (char c : hash) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

}  // namespace

std::string Authenticator::HashToken(absl::string_view token) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  EVP_Digest(token.data(), token.size(), digest, &length, EVP_sha256(), nullptr);
  return absl::BytesToHexString(absl::string_view(reinterpret_cast<const char*>(digest), length));
}

absl::StatusOr<Authenticator> Authenticator::FromText(absl::string_view text) {
  Authenticator auth;
  int line_number = 0;
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    ++line_number;
    line = absl::StripAsciiWhitespace(line);
    if (line.empty() || line.front() == '#') continue;
    const std::vector<absl::string_view> fields =
        absl::StrSplit(line, absl::ByAnyChar(" \t"), absl::SkipEmpty());
    const std::string hash = fields.size() == 2 ? absl::AsciiStrToLower(fields[1]) : "";
    if (fields.size() != 2 || !ValidTenant(fields[0]) || !ValidHash(hash)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "token file line ", line_number,
          ": expected '<tenant> <sha256 hex>' with tenant [a-z0-9-]{1,63} and 64 hex digits"));
    }
    if (!auth.tenant_by_hash_.emplace(hash, std::string(fields[0])).second) {
      return absl::InvalidArgumentError(
          absl::StrCat("token file line ", line_number, ": the same token hash appears twice"));
    }
  }
  if (auth.tenant_by_hash_.empty()) {
    return absl::InvalidArgumentError("token file: no tenants (a line is '<tenant> <sha256 hex>')");
  }
  return auth;
}

absl::StatusOr<Authenticator> Authenticator::FromFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return absl::InvalidArgumentError(absl::StrCat("token file: cannot read '", path, "'"));
  std::stringstream text;
  text << in.rdbuf();
  return FromText(text.str());
}

std::size_t Authenticator::tenants() const {
  std::set<std::string> names;
  for (const auto& [hash, tenant] : tenant_by_hash_) names.insert(tenant);
  return names.size();
}

absl::StatusOr<std::string> Authenticator::TenantOfHeader(const std::string* authorization) const {
  if (!enabled()) return std::string();
  if (authorization == nullptr) {
    return absl::UnauthenticatedError(
        "authorization: missing; send 'authorization: Bearer <token>' metadata");
  }
  absl::string_view value = *authorization;
  if (!absl::ConsumePrefix(&value, "Bearer ") || value.empty() || value.size() > 4096) {
    return absl::UnauthenticatedError("authorization: expected 'Bearer <token>'");
  }
  const auto it = tenant_by_hash_.find(HashToken(value));
  if (it == tenant_by_hash_.end()) {
    return absl::UnauthenticatedError("authorization: unknown token");
  }
  return it->second;
}

absl::StatusOr<std::string> Authenticator::TenantOf(const grpc::ServerContextBase& context) const {
  if (!enabled()) return std::string();
  const auto& metadata = context.client_metadata();
  const auto it = metadata.find("authorization");
  if (it == metadata.end()) return TenantOfHeader(nullptr);
  const std::string value(it->second.data(), it->second.size());
  return TenantOfHeader(&value);
}

grpc::Status TokenCheck::Process(const InputMetadata& auth_metadata, grpc::AuthContext*,
                                 OutputMetadata*, OutputMetadata*) {
  if (!auth_->enabled()) return grpc::Status::OK;
  const auto path = auth_metadata.find(":path");
  if (path == auth_metadata.end() ||
      !absl::StartsWith(absl::string_view(path->second.data(), path->second.size()),
                        "/oaipp.v1.MissionService/")) {
    return grpc::Status::OK;
  }
  const auto header = auth_metadata.find("authorization");
  std::string value;
  if (header != auth_metadata.end()) value.assign(header->second.data(), header->second.size());
  const absl::StatusOr<std::string> tenant =
      auth_->TenantOfHeader(header == auth_metadata.end() ? nullptr : &value);
  if (tenant.ok()) return grpc::Status::OK;
  return grpc::Status(grpc::StatusCode::UNAUTHENTICATED, std::string(tenant.status().message()));
}

}  // namespace oaipp::server
