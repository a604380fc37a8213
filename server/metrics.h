// Prometheus metrics of the service (prometheus-cpp), served by the binary
// on its own port.
//
//   Metrics metrics;                         // owns a prometheus::Registry
//   metrics.RecordCall("PlanPath", grpc::StatusCode::OK, 0.21);
//   MetricsHttp http(metrics.registry());    // serves GET /metrics
#pragma once

#include <memory>
#include <string>

#include "prometheus/counter.h"
#include "prometheus/family.h"
#include "prometheus/gauge.h"
#include "prometheus/histogram.h"
#include "prometheus/registry.h"

namespace oaipp::server {

class Metrics {
 public:
  Metrics();
  // One finished RPC: counted, and its latency observed, by method and status
  // code.
  void RecordCall(const std::string& method, int status_code, double seconds);
  // One plan: wall time and objective evaluations.
  void RecordPlan(double seconds, double evaluations);
  void SetMissions(double count, double map_bytes);
  [[nodiscard]] std::shared_ptr<prometheus::Registry> registry() const { return registry_; }

 private:
  std::shared_ptr<prometheus::Registry> registry_;
  prometheus::Family<prometheus::Counter>& calls_;
  prometheus::Family<prometheus::Histogram>& latency_;
  prometheus::Histogram& plan_seconds_;
  prometheus::Histogram& plan_evaluations_;
  prometheus::Gauge& missions_;
  prometheus::Gauge& map_bytes_;
};

}  // namespace oaipp::server
