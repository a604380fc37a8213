// oaipp-server's flags: missions held and the memory they may take.
// Defaults are ServerOptions' (server/server_options.h); ServerOptionsFromFlags
// (server/flags/flags.h) reads them.
#include <cstdint>
#include <string>

#include "absl/flags/flag.h"
#include "server/flags/flags.h"

ABSL_FLAG(int, max_missions, oaipp::server::kFlagDefaults.max_missions, "missions held at once");
ABSL_FLAG(int64_t, max_cells, oaipp::server::kFlagDefaults.max_cells,
          "cells per mission map (250,000: 1 km^2 at 2 m, on the sparse map)");
ABSL_FLAG(int64_t, max_dense_cells, oaipp::server::kFlagDefaults.max_dense_cells,
          "cells of the largest dense map (its covariance takes 8 n^2 bytes: 4096 cells = 134 "
          "MB); larger fields get the sparse map unless their spec asks for dense");
ABSL_FLAG(int, prior_cache, oaipp::server::kFlagDefaults.prior_cache,
          "prior covariances kept for missions over the same kind of field, and as many starting "
          "maps (ground under buildings fused) for missions over the same site (8 n^2 bytes "
          "each), and up to 2 sparse priors of large fields; 0: every mission computes its own)");
ABSL_FLAG(int, max_missions_per_tenant, oaipp::server::kFlagDefaults.max_missions_per_tenant,
          "missions one tenant may hold; 0: only --max_missions");
ABSL_FLAG(int64_t, max_memory_mb, oaipp::server::kFlagDefaults.max_memory_mb,
          "memory all missions together may need (admission control, estimated from each spec "
          "before anything is allocated); 0: half of this machine's memory");
ABSL_FLAG(int64_t, max_mission_memory_mb, oaipp::server::kFlagDefaults.max_mission_memory_mb,
          "memory one mission may need (see max_memory_mb)");
