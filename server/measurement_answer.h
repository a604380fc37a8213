// A measurement's answer (MeasurementResult) on the wire and back: what
// AddMeasurement returns, and what a stored record keeps of it when a replay
// could not compute it again (PersistFn).
#pragma once

#include "oaipp/v1/mission_service.pb.h"
#include "server/idempotency_memo.h"

namespace oaipp::server {

inline void FillMeasurementResponse(const MeasurementResult& result,
                                    v1::AddMeasurementResponse* out) {
  out->set_cells_fused(result.cells_fused);
  out->set_trace(result.trace);
  out->set_measurements_fused(result.measurements_fused);
  out->set_trace_measurements_fused(result.trace_measurements_fused);
}

inline MeasurementResult MeasurementResultFromProto(const v1::AddMeasurementResponse& response) {
  return {.cells_fused = response.cells_fused(),
          .trace = response.trace(),
          .measurements_fused = response.measurements_fused(),
          .trace_measurements_fused = response.trace_measurements_fused()};
}

}  // namespace oaipp::server
