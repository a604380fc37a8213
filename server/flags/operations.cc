// oaipp-server's flags: what operators see: logs, metrics, the live view.
// Defaults are ServerOptions' (server/server_options.h); ServerOptionsFromFlags
// (server/flags/flags.h) reads them.
#include <cstdint>
#include <string>

#include "absl/flags/flag.h"
#include "server/flags/flags.h"

ABSL_FLAG(std::string, log_level, oaipp::server::kFlagDefaults.log_level,
          "trace, debug, info, warn, error or off");
ABSL_FLAG(std::string, metrics_listen, oaipp::server::kFlagDefaults.metrics_listen,
          "Prometheus metrics address (host:port); empty disables");
ABSL_FLAG(int, web_port, oaipp::server::kFlagDefaults.web_port,
          "port of the live mission view, a read-only web page (docs/ground-stations.md); "
          "0: off");
ABSL_FLAG(std::string, web_address, oaipp::server::kFlagDefaults.web_address,
          "address the live view binds; beyond loopback only with --token_file and TLS "
          "(--tls_cert, --tls_key: the view then serves HTTPS; each request logs in with a token "
          "and sees its tenant's missions)");
ABSL_FLAG(std::string, web_hosts, oaipp::server::kFlagDefaults.web_hosts,
          "comma-separated host names (host or host:port) the live view answers to besides its "
          "address; requests naming another Host are refused (needed for a wildcard address)");
