#include "server/server_options.h"

#include <algorithm>
#include <string>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace oaipp::server {
namespace {

// Collects one message per setting out of its range.
class Problems {
 public:
  template <typename T>
  void AtLeast(const char* flag, T value, T least) {
    if (!(value >= least)) Add(flag, absl::StrCat("must be >= ", least, ", got ", value));
  }
  // least <= value < below (NaN fails).
  void InRange(const char* flag, double value, double least, double below) {
    if (!(value >= least && value < below)) {
      Add(flag, absl::StrCat("must be in [", least, ", ", below, "), got ", value));
    }
  }
  void Add(const char* flag, const std::string& reason) {
    problems_.push_back(absl::StrCat("--", flag, ": ", reason));
  }
  absl::Status status() const {
    if (problems_.empty()) return absl::OkStatus();
    return absl::InvalidArgumentError(absl::StrJoin(problems_, "; "));
  }

 private:
  std::vector<std::string> problems_;
};

}  // namespace

absl::Status ServerOptions::Validate() const {
  Problems p;
  if (listen.empty()) p.Add("listen", "must name an address (host:port)");
  p.AtLeast("worker_threads", worker_threads, 2);
  p.InRange("shutdown_grace_s", shutdown_grace_s, 0, 1e6);
  p.AtLeast("max_streams", max_streams, 1);
  p.AtLeast("max_streams_per_client", max_streams_per_client, 1);
  if (tls_cert.empty() != tls_key.empty()) p.Add("tls_key", "--tls_cert and --tls_key go together");
  if (!tls_client_ca.empty() && tls_cert.empty()) {
    p.Add("tls_client_ca", "needs --tls_cert and --tls_key");
  }
  if (tls_cert.empty() && !allow_insecure_remote && !listen.empty() && !IsLoopbackAddress(listen)) {
    p.Add("listen",
          "not a loopback address and TLS is off: give --tls_cert and --tls_key, or "
          "--allow_insecure_remote to serve in the clear");
  }

  p.AtLeast("planning_threads", planning_threads, 1);
  p.AtLeast("planning_queue", planning_queue, 0);
  if (planning_nice < 0 || planning_nice > 19) {
    p.Add("planning_nice", absl::StrCat("must be in [0, 19], got ", planning_nice));
  }
  if (!(max_planning_s > 0 && max_planning_s < 1e6)) {
    p.Add("max_planning_s", absl::StrCat("must be in (0, 1e6), got ", max_planning_s));
  }
  p.AtLeast("max_plans_per_tenant", max_plans_per_tenant, 0);
  p.InRange("shed_above", shed_above, 0, 1e6);
  p.InRange("shed_after_wait_s", shed_after_wait_s, 0, 1e6);
  if (!(min_search_fraction > 0 && min_search_fraction <= 1)) {
    p.Add("min_search_fraction", absl::StrCat("must be in (0, 1], got ", min_search_fraction));
  }
  p.InRange("plan_latency_s", plan_latency_s, 0, 1e6);
  p.AtLeast("max_take_off_plans", max_take_off_plans, 0);
  p.InRange("take_off_patience_s", take_off_patience_s, 0, 1e6);
  if (dense_backend != "openblas" && dense_backend != "eigen") {
    p.Add("dense_backend", "must be openblas or eigen");
  }
  if (objective_precision != "double" && objective_precision != "single") {
    p.Add("objective_precision", "must be double or single");
  }

  p.AtLeast("max_missions", max_missions, 1);
  p.AtLeast("max_cells", max_cells, std::int64_t{1});
  p.AtLeast("max_dense_cells", max_dense_cells, std::int64_t{1});
  p.AtLeast("prior_cache", prior_cache, 0);
  p.AtLeast("max_missions_per_tenant", max_missions_per_tenant, 0);
  // MB to bytes must not overflow.
  constexpr std::int64_t kMostMb = std::int64_t{1} << 40;
  if (max_memory_mb < 0 || max_memory_mb > kMostMb) {
    p.Add("max_memory_mb", absl::StrCat("must be in [0, 2^40], got ", max_memory_mb));
  }
  if (max_mission_memory_mb < 0 || max_mission_memory_mb > kMostMb) {
    p.Add("max_mission_memory_mb",
          absl::StrCat("must be in [0, 2^40], got ", max_mission_memory_mb));
  }

  if (store.empty()) p.Add("store", "must be sqlite, memory or a postgresql:// URI");
  p.AtLeast("snapshot_every", snapshot_every, 0);
  p.AtLeast("recovery_threads", recovery_threads, 1);
  if (keep_finished <= absl::ZeroDuration()) p.Add("keep_finished", "must be > 0");
  if (keep_idle <= absl::ZeroDuration()) p.Add("keep_idle", "must be > 0");

  if (replica_id.size() > 64 || !std::all_of(replica_id.begin(), replica_id.end(), [](char c) {
        return absl::ascii_isalnum(c) || c == '-' || c == '_' || c == '.' || c == ':';
      })) {
    p.Add("replica_id", "at most 64 letters, digits, '-', '_', '.' or ':'");
  }
  if (ring_id < 0 || ring_id > 1'000'000) {
    p.Add("ring_id", "must be 0 (none) or the proxies' id of this server, 1 to 1000000");
  } else if (ring_id > 0 && !cluster) {
    p.Add("ring_id", "is for a replica of a cluster (--cluster)");
  }
  if (ring_id_from_ordinal) {
    if (ring_id != 0) {
      p.Add("ring_id_from_ordinal", "conflicts with --ring_id; give one of them");
    } else if (!cluster) {
      p.Add("ring_id_from_ordinal", "is for a replica of a cluster (--cluster)");
    } else if (EffectiveRingId() == 0) {
      p.Add("ring_id_from_ordinal",
            "needs a --replica_id that ends in a number below 1000000 (a StatefulSet pod's "
            "name, oaipp-server-0)");
    }
  }
  p.AtLeast("standby_missions", standby_missions, 0);
  if (silent_after < absl::Milliseconds(50) || silent_after > absl::Seconds(60)) {
    p.Add("silent_after",
          absl::StrCat("must be in [50ms, 60s], got ", absl::FormatDuration(silent_after)));
  } else if (silent_after != kDefaultSilentAfter && !cluster) {
    p.Add("silent_after", "is for a replica of a cluster (--cluster)");
  }
  if (cluster && !absl::StartsWith(store, "postgres")) {
    p.Add("cluster", "needs a store the replicas share: --store=postgresql://...");
  }

  static const char* const kLevels[] = {"trace", "debug", "info", "warn", "error", "off"};
  if (std::find(std::begin(kLevels), std::end(kLevels), log_level) == std::end(kLevels)) {
    p.Add("log_level", "must be trace, debug, info, warn, error or off");
  }
  if (web_port < 0 || web_port > 65535) {
    p.Add("web_port", absl::StrCat("must be in [0, 65535], got ", web_port));
  }
  return p.status();
}

int ServerOptions::EffectiveRingId() const {
  if (!ring_id_from_ordinal) return ring_id;
  // The digits that end replica_id: at least one, at most six.
  std::size_t start = replica_id.size();
  while (start > 0 && absl::ascii_isdigit(static_cast<unsigned char>(replica_id[start - 1]))) {
    --start;
  }
  int ordinal = 0;
  if (start == replica_id.size() || replica_id.size() - start > 6 ||
      !absl::SimpleAtoi(absl::string_view(replica_id).substr(start), &ordinal)) {
    return 0;
  }
  return ordinal + 1;
}

bool IsLoopbackAddress(const std::string& address) {
  if (absl::StartsWith(address, "unix:") || absl::StartsWith(address, "unix-abstract:")) {
    return true;
  }
  std::string host = address.substr(0, address.rfind(':'));
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
    host = host.substr(1, host.size() - 2);
  }
  return host == "localhost" || host == "::1" || absl::StartsWith(host, "127.");
}

}  // namespace oaipp::server
