#include "api/map.h"

#include "core/mapping/field_grid.h"

namespace oaipp::api {

void MapToProto(const GpMap& map, bool include_cells, v1::GetMapResponse* out) {
  const FieldGrid& grid = map.grid();
  out->set_nx(grid.nx());
  out->set_ny(grid.ny());
  out->set_resolution_m(grid.resolution_m());
  out->set_x_min_m(grid.min_W().x());
  out->set_y_min_m(grid.min_W().y());
  out->set_trace(map.Trace());
  out->clear_mean();
  out->clear_variance();
  if (!include_cells) return;
  const int n = map.num_cells();
  out->mutable_mean()->Reserve(n);
  out->mutable_variance()->Reserve(n);
  for (int i = 0; i < n; ++i) {
    out->add_mean(map.Mean()[i]);
    out->add_variance(map.Variance(i));
  }
}

}  // namespace oaipp::api
