// core -> proto for GetMap: the grid description, Tr(P) and, on request,
// the mean and variance of every cell, of a dense map (GpMap) or of any
// map read as a MapView (a large field's, server/large_field_map.h).
//
//   MapToProto(map, request.include_cells(), &response);
#pragma once

#include "Eigen/Core"
#include "core/mapping/field_grid.h"
#include "core/mapping/gp_map.h"
#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::api {

// A whole map as its readers see it, whatever holds it: borrowed, valid
// while the reader runs.
struct MapView {
  const FieldGrid* grid = nullptr;
  const Eigen::VectorXd* mean = nullptr;       // one per cell
  const Eigen::VectorXd* variances = nullptr;  // one per cell
  double trace = 0.0;
};

// Fills the grid description and Tr(P) of *out, and mean and variance
// (row-major, row along y) when include_cells. Leaves out->png alone.
void MapToProto(const MapView& map, bool include_cells, v1::GetMapResponse* out);
void MapToProto(const GpMap& map, bool include_cells, v1::GetMapResponse* out);

}  // namespace oaipp::api
