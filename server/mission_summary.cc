#include "server/mission_summary.h"

#include <utility>

namespace oaipp::server {

PublishedSummary::Summary PublishedSummary::Get() const {
  absl::MutexLock lock(&mu_);
  return summary_;
}

void PublishedSummary::Replace(Summary next, bool sparse) {
  absl::MutexLock lock(&mu_);
  if (sparse && summary_.trace_version > next.trace_version) {
    next.trace = summary_.trace;
    next.trace_measurements_fused = summary_.trace_measurements_fused;
    next.trace_version = summary_.trace_version;
  }
  summary_ = std::move(next);
}

void PublishedSummary::SetNewerTrace(double trace, std::int64_t measurements_fused,
                                     std::int64_t version) {
  absl::MutexLock lock(&mu_);
  if (version > summary_.trace_version) {
    summary_.trace = trace;
    summary_.trace_measurements_fused = measurements_fused;
    summary_.trace_version = version;
  }
}

void PublishedSummary::RestoreTrace(double trace, std::int64_t measurements_fused) {
  absl::MutexLock lock(&mu_);
  summary_.trace = trace;
  summary_.trace_measurements_fused = measurements_fused;
}

}  // namespace oaipp::server
