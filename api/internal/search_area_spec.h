// MissionSpec.search_areas <-> MissionConfig's search area: the rings of the
// proto read into polygons (bounded before anything is copied), validated,
// and rasterised onto the field's grid (api/search_area.h); and written back.
#pragma once

#include <span>

#include "absl/status/status.h"
#include "api/mission_config.h"
#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::api::internal {

// Fills c.search_area from spec.search_areas (leaves it null when the list
// is empty); the field must already be in `c`. Rings in
// metres only: ResolveGeoFields (api/geodetic.h) has converted geodetic
// rings. InvalidArgument naming the part ("spec.search_areas[1].holes[0]")
// for a ring ValidateSearchArea refuses, an odd number of coordinates, more
// than kMaxAreaVertices vertices in all, or an area that holds the centre
// of no cell of the field.
[[nodiscard]] absl::Status FillSearchAreas(
    const google::protobuf::RepeatedPtrField<v1::AreaPolygon>& areas, MissionConfig& c);

// Appends `areas` to spec->search_areas, in metres.
void WriteSearchAreas(std::span<const AreaPolygon> areas, v1::MissionSpec* spec);

}  // namespace oaipp::api::internal
