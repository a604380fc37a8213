// oaipp-server's flags: who gets in: TLS and tenants' tokens.
// Defaults are ServerOptions' (server/server_options.h); ServerOptionsFromFlags
// (server/flags/flags.h) reads them.
#include <cstdint>
#include <string>

#include "absl/flags/flag.h"
#include "server/flags/flags.h"

ABSL_FLAG(std::string, tls_cert, oaipp::server::kFlagDefaults.tls_cert,
          "PEM server certificate (chain); with --tls_key turns TLS on");
ABSL_FLAG(std::string, tls_key, oaipp::server::kFlagDefaults.tls_key,
          "PEM private key of --tls_cert");
ABSL_FLAG(std::string, tls_client_ca, oaipp::server::kFlagDefaults.tls_client_ca,
          "PEM CA bundle: clients must present a certificate it signed (mutual TLS)");
ABSL_FLAG(bool, allow_insecure_remote, oaipp::server::kFlagDefaults.allow_insecure_remote,
          "listen on a non-loopback address without TLS (calls and tokens cross the network in "
          "the clear)");
ABSL_FLAG(std::string, token_file, oaipp::server::kFlagDefaults.token_file,
          "bearer tokens: lines '<tenant> <sha256 hex of token>'; callers must send "
          "'authorization: Bearer <token>' and see only their tenant's missions");
