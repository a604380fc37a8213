// oaipp-server's flags: calls: where the server listens and how many it serves.
// Defaults are ServerOptions' (server/server_options.h); ServerOptionsFromFlags
// (server/flags/flags.h) reads them.
#include <cstdint>
#include <string>

#include "absl/flags/flag.h"
#include "server/flags/flags.h"

ABSL_FLAG(std::string, listen, oaipp::server::kFlagDefaults.listen,
          "gRPC listen address (host:port)");
ABSL_FLAG(int, worker_threads, oaipp::server::kFlagDefaults.worker_threads,
          "most threads serving the quick RPCs at once (streams and plans hold none); past it a "
          "call is RESOURCE_EXHAUSTED. A fleet creating its missions at once needs one each");
ABSL_FLAG(bool, reflection, oaipp::server::kFlagDefaults.reflection,
          "serve gRPC server reflection (for grpcurl and similar tools)");
ABSL_FLAG(double, shutdown_grace_s, oaipp::server::kFlagDefaults.shutdown_grace_s,
          "time in-flight calls get to finish on SIGTERM");
ABSL_FLAG(int, max_streams, oaipp::server::kFlagDefaults.max_streams,
          "open WatchMission streams in all");
ABSL_FLAG(int, max_streams_per_client, oaipp::server::kFlagDefaults.max_streams_per_client,
          "open WatchMission streams per client (per tenant with --token_file, per connection "
          "without)");
