// oaipp-server's flags: a replica of a cluster (docs/cluster.md).
// Defaults are ServerOptions' (server/server_options.h); ServerOptionsFromFlags
// (server/flags/flags.h) reads them.
#include <cstdint>
#include <string>

#include "absl/flags/flag.h"
#include "server/flags/flags.h"

ABSL_FLAG(std::string, replica_id, oaipp::server::kFlagDefaults.replica_id,
          "a name for this server, sent back on every call as the x-oaipp-replica header "
          "(which replica of a cluster answered); empty: not sent");
ABSL_FLAG(int, ring_id, oaipp::server::kFlagDefaults.ring_id,
          "with --cluster: this replica's id on the proxies' consistent-hash ring (HAProxy's "
          "`server ... id N`, deploy/cluster/haproxy.cfg.in). With it, the replica keeps warm "
          "standbys: the missions the proxies would send it if their holder died, read and "
          "replayed ahead, so that taking one over reads only what was written since. 0: none");
ABSL_FLAG(bool, ring_id_from_ordinal, oaipp::server::kFlagDefaults.ring_id_from_ordinal,
          "with --cluster, instead of --ring_id: the ring id is the number that ends "
          "--replica_id, plus one (a StatefulSet's pod oaipp-server-0 is the proxies' "
          "`server ... id 1`, deploy/k8s/cluster/proxy.yaml)");
ABSL_FLAG(int, standby_missions, oaipp::server::kFlagDefaults.standby_missions,
          "with --ring_id: at most this many missions on warm standby (each costs the memory of "
          "a mission held, within --max_memory_mb, and the CPU of fusing its measurements "
          "again); 0: none");
ABSL_FLAG(absl::Duration, silent_after, oaipp::server::kFlagDefaults.silent_after,
          "with --cluster: a replica that has said nothing for this long is silent, and the "
          "others take its missions over. It says it is alive five times in this time; raise it "
          "where a replica can stall longer than that (a CPU quota, a slow store) and a live "
          "replica's missions would move. Takeovers after a kill take this much longer, and a "
          "mission whose calls go to another replica (the ring changed) moves four times this "
          "after its last call. 50ms to 60s");
ABSL_FLAG(bool, cluster, oaipp::server::kFlagDefaults.cluster,
          "this server is one of several replicas sharing a PostgreSQL --store behind a proxy "
          "that routes by the x-oaipp-mission header: it loads no mission at start, takes a "
          "mission over from the store when a call for it arrives, and drops a mission another "
          "replica has taken (docs/cluster.md)");
