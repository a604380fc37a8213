#include "api/map.h"

namespace oaipp::api {

void MapToProto(const MapView& map, bool include_cells, v1::GetMapResponse* out) {
  const FieldGrid& grid = *map.grid;
  out->set_nx(grid.nx());
  out->set_ny(grid.ny());
  out->set_resolution_m(grid.resolution_m());
  out->set_x_min_m(grid.min_W().x());
  out->set_y_min_m(grid.min_W().y());
  out->set_trace(map.trace);
  out->clear_mean();
  out->clear_variance();
  if (!include_cells) return;
  out->mutable_mean()->Add(map.mean->begin(), map.mean->end());
  out->mutable_variance()->Add(map.variances->begin(), map.variances->end());
}

void MapToProto(const GpMap& map, bool include_cells, v1::GetMapResponse* out) {
  const Eigen::VectorXd variances = include_cells ? map.Variances() : Eigen::VectorXd();
  MapToProto(
      MapView{
          .grid = &map.grid(), .mean = &map.Mean(), .variances = &variances, .trace = map.Trace()},
      include_cells, out);
}

}  // namespace oaipp::api
