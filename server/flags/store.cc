// oaipp-server's flags: where missions live, and for how long.
// Defaults are ServerOptions' (server/server_options.h); ServerOptionsFromFlags
// (server/flags/flags.h) reads them.
#include <cstdint>
#include <string>

#include "absl/flags/flag.h"
#include "absl/time/time.h"
#include "server/flags/flags.h"

ABSL_FLAG(std::string, store, oaipp::server::kFlagDefaults.store,
          "where missions are kept: sqlite (one file, missions.db, under --data_dir), a "
          "PostgreSQL URI (postgresql://user@host:port/db; for several servers), or memory "
          "(lost on restart); with a store every acknowledged change is durable first");
ABSL_FLAG(std::string, data_dir, oaipp::server::kFlagDefaults.data_dir,
          "folder of the sqlite store (created at start); back it up with sqlite3's .backup");
ABSL_FLAG(int, snapshot_every, oaipp::server::kFlagDefaults.snapshot_every,
          "with a store: snapshot a mission's map and state after this many measurements (or 4x "
          "as many records) since its last one, so recovery replays at most that many; 0: never");
ABSL_FLAG(int, recovery_threads, oaipp::server::kFlagDefaults.recovery_threads,
          "threads that rebuild missions from the store at start");
ABSL_FLAG(absl::Duration, keep_finished, oaipp::server::kFlagDefaults.keep_finished,
          "how long a mission whose flight budget is spent is kept after its last change, "
          "then deleted with its records ('inf': forever)");
ABSL_FLAG(absl::Duration, keep_idle, oaipp::server::kFlagDefaults.keep_idle,
          "how long any mission is kept after its last change ('inf': forever)");
