// oaipp-server's flags: who gets in: TLS and tenants' tokens.
// Defaults are ServerOptions' (server/server_options.h); ServerOptionsFromFlags
// (server/flags/flags.h) reads them.
#include <cstdint>
#include <string>

#include "absl/flags/flag.h"
#include "server/server_options.h"

namespace {
const oaipp::server::ServerOptions kDefaults;
}  // namespace

ABSL_FLAG(std::string, tls_cert, kDefaults.tls_cert,
          "PEM server certificate (chain); with --tls_key turns TLS on");
ABSL_FLAG(std::string, tls_key, kDefaults.tls_key, "PEM private key of --tls_cert");
ABSL_FLAG(std::string, tls_client_ca, kDefaults.tls_client_ca,
          "PEM CA bundle: clients must present a certificate it signed (mutual TLS)");
ABSL_FLAG(bool, allow_insecure_remote, kDefaults.allow_insecure_remote,
          "listen on a non-loopback address without TLS (calls and tokens cross the network in "
          "the clear)");
ABSL_FLAG(std::string, token_file, kDefaults.token_file,
          "bearer tokens: lines '<tenant> <sha256 hex of token>'; callers must send "
          "'authorization: Bearer <token>' and see only their tenant's missions");
