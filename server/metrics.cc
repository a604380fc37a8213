#include "server/metrics.h"

namespace oaipp::server {

Metrics::Metrics()
    : registry_(std::make_shared<prometheus::Registry>()),
      calls_(prometheus::BuildCounter()
                 .Name("oaipp_rpc_calls_total")
                 .Help("RPCs finished, by method and gRPC status code")
                 .Register(*registry_)),
      latency_(prometheus::BuildHistogram()
                   .Name("oaipp_rpc_latency_seconds")
                   .Help("RPC latency by method and gRPC status code")
                   .Register(*registry_)),
      plan_seconds_(prometheus::BuildHistogram()
                        .Name("oaipp_plan_seconds")
                        .Help("Planner wall time per plan")
                        .Register(*registry_)
                        .Add({}, prometheus::Histogram::BucketBoundaries{0.01, 0.05, 0.1, 0.2, 0.5,
                                                                         1, 2, 5, 10})),
      plan_evaluations_(
          prometheus::BuildHistogram()
              .Name("oaipp_plan_evaluations")
              .Help("Objective evaluations per plan")
              .Register(*registry_)
              .Add({}, prometheus::Histogram::BucketBoundaries{10, 50, 100, 200, 500, 1000, 2000})),
      missions_(prometheus::BuildGauge()
                    .Name("oaipp_missions")
                    .Help("Missions held")
                    .Register(*registry_)
                    .Add({})),
      map_bytes_(prometheus::BuildGauge()
                     .Name("oaipp_map_bytes")
                     .Help("Memory held by the missions' maps and ESDFs, bytes")
                     .Register(*registry_)
                     .Add({})) {}

void Metrics::RecordCall(const std::string& method, int status_code, double seconds) {
  // prometheus-cpp's Family::Add is thread-safe and returns the same metric
  // for the same labels.
  calls_.Add({{"method", method}, {"code", std::to_string(status_code)}}).Increment();
  latency_
      .Add({{"method", method}, {"code", std::to_string(status_code)}},
           prometheus::Histogram::BucketBoundaries{0.001, 0.005, 0.01, 0.05, 0.1, 0.5, 1, 5})
      .Observe(seconds);
}

void Metrics::RecordPlan(double seconds, double evaluations) {
  plan_seconds_.Observe(seconds);
  plan_evaluations_.Observe(evaluations);
}

void Metrics::SetMissions(double count, double map_bytes) {
  missions_.Set(count);
  map_bytes_.Set(map_bytes);
}

}  // namespace oaipp::server
