// The map picture's input checks (RenderMapPng and ComputeMapLayout run
// them first): each error names the field as render/map_render.h spells it
// and says why, without printing more than the offending value.
#pragma once

#include "absl/status/status.h"
#include "render/map_render.h"

namespace oaipp::render {

// nx and ny in [1, kMaxCellsPerSide], a positive resolution, a finite
// origin and far corner.
[[nodiscard]] absl::Status ValidateGrid(const MapGrid& grid);
// Every overlay point finite; every obstacle footprint of 3 vertices or more.
[[nodiscard]] absl::Status ValidateOverlay(const Overlay& overlay);
// One mean and one standard deviation per cell of `grid`.
[[nodiscard]] absl::Status ValidateLayers(const MapGrid& grid, const MapLayers& layers);

}  // namespace oaipp::render
