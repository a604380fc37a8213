// core -> proto for GetMap: the grid description, Tr(P) and, on request,
// the mean and variance of every cell.
//
//   MapToProto(map, request.include_cells(), &response);
#pragma once

#include "core/mapping/gp_map.h"
#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::api {

// Fills the grid description and Tr(P) of *out, and mean and variance
// (row-major, row along y) when include_cells. Leaves out->png alone.
void MapToProto(const GpMap& map, bool include_cells, v1::GetMapResponse* out);

}  // namespace oaipp::api
