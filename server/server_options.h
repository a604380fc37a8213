// Every setting of a server, its default and its check, in one place.
//
// A field is named as its oaipp-server flag (server/flags/ declares the
// flags, with these defaults, and reads them into a ServerOptions);
// Server::Start (server.h) assembles a server from it. Programs that run a
// server in process, the load benchmark among them, fill one in the same
// way, so that no setting is declared twice.
//
//   ServerOptions options;                 // the defaults
//   options.listen = "127.0.0.1:0";        // any free port
//   options.store = "memory";
//   if (absl::Status valid = options.Validate(); !valid.ok()) ...
#pragma once

#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "absl/time/time.h"

namespace oaipp::server {

// How long a replica of a cluster may say nothing before it is silent
// (ServerOptions::silent_after).
inline constexpr absl::Duration kDefaultSilentAfter = absl::Milliseconds(500);

struct ServerOptions {
  // --- calls
  std::string listen = "127.0.0.1:50051";  // host:port, [v6]:port or unix:path
  int worker_threads = 128;                // >= 2
  bool reflection = true;
  double shutdown_grace_s = 10.0;   // >= 0
  int max_streams = 256;            // >= 1
  int max_streams_per_client = 16;  // >= 1

  // --- who gets in
  std::string tls_cert;
  std::string tls_key;
  std::string tls_client_ca;
  bool allow_insecure_remote = false;
  std::string token_file;

  // --- planning and overload
  int planning_threads = 2;                    // >= 1
  int planning_queue = 128;                    // >= 0
  int planning_nice = 10;                      // 0..19
  double max_planning_s = 60.0;                // (0, 1e6)
  int max_plans_per_tenant = 0;                // >= 0; 0: no quota
  double shed_above = 2.0;                     // [0, 1e6); 0: never shed
  double min_search_fraction = 0.1;            // (0, 1]
  double shed_after_wait_s = 1.0;              // [0, 1e6); 0: the queue rule alone
  double plan_latency_s = 0.0;                 // [0, 1e6); 0: no bound
  int max_take_off_plans = 0;                  // >= 0; 0: no pacing
  double take_off_patience_s = 5.0;            // [0, 1e6)
  std::string dense_backend = "openblas";      // openblas or eigen
  std::string objective_precision = "single";  // single or double

  // --- missions and memory
  int max_missions = 64;                      // >= 1
  std::int64_t max_cells = 250'000;           // >= 1
  std::int64_t max_dense_cells = 4096;        // >= 1
  int prior_cache = 4;                        // >= 0
  int max_missions_per_tenant = 0;            // >= 0; 0: only max_missions
  std::int64_t max_memory_mb = 0;             // >= 0; 0: half of the machine's memory
  std::int64_t max_mission_memory_mb = 4096;  // >= 0

  // --- where missions live
  std::string store = "sqlite";  // sqlite, memory or postgresql://...
  std::string data_dir = "./data";
  int snapshot_every = 16;                             // >= 0; 0: never
  int recovery_threads = 2;                            // >= 1
  absl::Duration keep_finished = absl::Hours(7 * 24);  // > 0
  absl::Duration keep_idle = absl::Hours(30 * 24);     // > 0

  // --- a cluster's replica
  std::string replica_id;     // at most 64 of [A-Za-z0-9-_.:]
  bool cluster = false;       // needs a postgresql:// store
  int ring_id = 0;            // 0..1000000, only with cluster; 0: no warm standbys
  int standby_missions = 64;  // >= 0
  // Only with cluster: a replica whose heartbeats have stopped for this
  // long is silent, and its missions are free (RegistryLimits::
  // silent_after). 50 ms .. 60 s.
  absl::Duration silent_after = kDefaultSilentAfter;
  // Only with cluster, not with ring_id: the ring id is the number that
  // ends replica_id, plus one (a StatefulSet's pod oaipp-server-0 is the
  // proxies' id 1).
  bool ring_id_from_ordinal = false;

  // --- what operators see
  std::string metrics_listen = "127.0.0.1:9464";  // empty: off
  std::string log_level = "info";                 // trace, debug, info, warn, error or off
  int web_port = 0;                               // 0..65535; 0: off
  std::string web_address = "127.0.0.1";
  std::string web_hosts;  // comma-separated host names besides web_address

  // OK, or InvalidArgument naming every setting out of its range by its
  // flag, each with the reason ("--planning_threads: must be >= 1, got 0;
  // --web_port: ..."). Files (TLS, tokens) and addresses are checked when
  // the server starts, where they are used.
  [[nodiscard]] absl::Status Validate() const;
  // ring_id, or with ring_id_from_ordinal the one replica_id gives (0 when
  // it gives none; Validate refuses that).
  [[nodiscard]] int EffectiveRingId() const;
};

// Whether `address` (host:port, [v6]:port or unix:path) can be reached only
// from this machine.
[[nodiscard]] bool IsLoopbackAddress(const std::string& address);

}  // namespace oaipp::server
