#include "server/flags/flags.h"

#include <cstdint>
#include <string>

#include "absl/flags/declare.h"
#include "absl/flags/flag.h"
#include "absl/flags/usage.h"
#include "absl/flags/usage_config.h"
#include "absl/strings/match.h"
#include "absl/time/time.h"

ABSL_DECLARE_FLAG(std::string, listen);
ABSL_DECLARE_FLAG(int, worker_threads);
ABSL_DECLARE_FLAG(int, planning_threads);
ABSL_DECLARE_FLAG(int, planning_queue);
ABSL_DECLARE_FLAG(int, planning_nice);
ABSL_DECLARE_FLAG(int, max_missions);
ABSL_DECLARE_FLAG(int64_t, max_cells);
ABSL_DECLARE_FLAG(int64_t, max_dense_cells);
ABSL_DECLARE_FLAG(int, prior_cache);
ABSL_DECLARE_FLAG(std::string, log_level);
ABSL_DECLARE_FLAG(std::string, metrics_listen);
ABSL_DECLARE_FLAG(std::string, store);
ABSL_DECLARE_FLAG(std::string, data_dir);
ABSL_DECLARE_FLAG(double, shutdown_grace_s);
ABSL_DECLARE_FLAG(int, max_streams);
ABSL_DECLARE_FLAG(int, max_streams_per_client);
ABSL_DECLARE_FLAG(int, max_plans_per_tenant);
ABSL_DECLARE_FLAG(double, max_planning_s);
ABSL_DECLARE_FLAG(double, shed_above);
ABSL_DECLARE_FLAG(std::string, dense_backend);
ABSL_DECLARE_FLAG(std::string, objective_precision);
ABSL_DECLARE_FLAG(double, min_search_fraction);
ABSL_DECLARE_FLAG(double, shed_after_wait_s);
ABSL_DECLARE_FLAG(double, plan_latency_s);
ABSL_DECLARE_FLAG(int, max_take_off_plans);
ABSL_DECLARE_FLAG(double, take_off_patience_s);
ABSL_DECLARE_FLAG(int, max_missions_per_tenant);
ABSL_DECLARE_FLAG(int64_t, max_memory_mb);
ABSL_DECLARE_FLAG(int64_t, max_mission_memory_mb);
ABSL_DECLARE_FLAG(std::string, tls_cert);
ABSL_DECLARE_FLAG(std::string, tls_key);
ABSL_DECLARE_FLAG(std::string, tls_client_ca);
ABSL_DECLARE_FLAG(bool, allow_insecure_remote);
ABSL_DECLARE_FLAG(std::string, token_file);
ABSL_DECLARE_FLAG(bool, reflection);
ABSL_DECLARE_FLAG(int, snapshot_every);
ABSL_DECLARE_FLAG(int, recovery_threads);
ABSL_DECLARE_FLAG(absl::Duration, keep_finished);
ABSL_DECLARE_FLAG(absl::Duration, keep_idle);
ABSL_DECLARE_FLAG(std::string, replica_id);
ABSL_DECLARE_FLAG(bool, cluster);
ABSL_DECLARE_FLAG(int, ring_id);
ABSL_DECLARE_FLAG(int, standby_missions);
ABSL_DECLARE_FLAG(absl::Duration, silent_after);
ABSL_DECLARE_FLAG(bool, ring_id_from_ordinal);
ABSL_DECLARE_FLAG(int, web_port);
ABSL_DECLARE_FLAG(std::string, web_address);
ABSL_DECLARE_FLAG(std::string, web_hosts);

namespace oaipp::server {

ServerOptions ServerOptionsFromFlags() {
  ServerOptions options;
  options.listen = absl::GetFlag(FLAGS_listen);
  options.worker_threads = absl::GetFlag(FLAGS_worker_threads);
  options.planning_threads = absl::GetFlag(FLAGS_planning_threads);
  options.planning_queue = absl::GetFlag(FLAGS_planning_queue);
  options.planning_nice = absl::GetFlag(FLAGS_planning_nice);
  options.max_missions = absl::GetFlag(FLAGS_max_missions);
  options.max_cells = absl::GetFlag(FLAGS_max_cells);
  options.max_dense_cells = absl::GetFlag(FLAGS_max_dense_cells);
  options.prior_cache = absl::GetFlag(FLAGS_prior_cache);
  options.log_level = absl::GetFlag(FLAGS_log_level);
  options.metrics_listen = absl::GetFlag(FLAGS_metrics_listen);
  options.store = absl::GetFlag(FLAGS_store);
  options.data_dir = absl::GetFlag(FLAGS_data_dir);
  options.shutdown_grace_s = absl::GetFlag(FLAGS_shutdown_grace_s);
  options.max_streams = absl::GetFlag(FLAGS_max_streams);
  options.max_streams_per_client = absl::GetFlag(FLAGS_max_streams_per_client);
  options.max_plans_per_tenant = absl::GetFlag(FLAGS_max_plans_per_tenant);
  options.max_planning_s = absl::GetFlag(FLAGS_max_planning_s);
  options.shed_above = absl::GetFlag(FLAGS_shed_above);
  options.dense_backend = absl::GetFlag(FLAGS_dense_backend);
  options.objective_precision = absl::GetFlag(FLAGS_objective_precision);
  options.min_search_fraction = absl::GetFlag(FLAGS_min_search_fraction);
  options.shed_after_wait_s = absl::GetFlag(FLAGS_shed_after_wait_s);
  options.plan_latency_s = absl::GetFlag(FLAGS_plan_latency_s);
  options.max_take_off_plans = absl::GetFlag(FLAGS_max_take_off_plans);
  options.take_off_patience_s = absl::GetFlag(FLAGS_take_off_patience_s);
  options.max_missions_per_tenant = absl::GetFlag(FLAGS_max_missions_per_tenant);
  options.max_memory_mb = absl::GetFlag(FLAGS_max_memory_mb);
  options.max_mission_memory_mb = absl::GetFlag(FLAGS_max_mission_memory_mb);
  options.tls_cert = absl::GetFlag(FLAGS_tls_cert);
  options.tls_key = absl::GetFlag(FLAGS_tls_key);
  options.tls_client_ca = absl::GetFlag(FLAGS_tls_client_ca);
  options.allow_insecure_remote = absl::GetFlag(FLAGS_allow_insecure_remote);
  options.token_file = absl::GetFlag(FLAGS_token_file);
  options.reflection = absl::GetFlag(FLAGS_reflection);
  options.snapshot_every = absl::GetFlag(FLAGS_snapshot_every);
  options.recovery_threads = absl::GetFlag(FLAGS_recovery_threads);
  options.keep_finished = absl::GetFlag(FLAGS_keep_finished);
  options.keep_idle = absl::GetFlag(FLAGS_keep_idle);
  options.replica_id = absl::GetFlag(FLAGS_replica_id);
  options.cluster = absl::GetFlag(FLAGS_cluster);
  options.ring_id = absl::GetFlag(FLAGS_ring_id);
  options.standby_missions = absl::GetFlag(FLAGS_standby_missions);
  options.silent_after = absl::GetFlag(FLAGS_silent_after);
  options.ring_id_from_ordinal = absl::GetFlag(FLAGS_ring_id_from_ordinal);
  options.web_port = absl::GetFlag(FLAGS_web_port);
  options.web_address = absl::GetFlag(FLAGS_web_address);
  options.web_hosts = absl::GetFlag(FLAGS_web_hosts);
  return options;
}

void SetServerFlagsUsage(absl::string_view usage) {
  absl::SetProgramUsageMessage(usage);
  absl::FlagsUsageConfig config;
  config.contains_helpshort_flags = [](absl::string_view file) {
    return absl::StrContains(file, "server/flags/");
  };
  config.contains_help_flags = config.contains_helpshort_flags;
  absl::SetFlagsUsageConfig(config);
}

}  // namespace oaipp::server
