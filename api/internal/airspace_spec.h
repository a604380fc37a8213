// MissionSpec.fence and .no_fly_zones <-> MissionConfig::airspace
// (core/environment/airspace.h): read, bounded before anything is copied,
// validated with the API's field names; and written back.
#pragma once

#include "absl/status/status.h"
#include "api/mission_config.h"
#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::api::internal {

// Fills c.airspace from spec.fence and spec.no_fly_zones (metres only:
// ResolveGeoFields has converted WGS84). InvalidArgument naming the field
// ("spec.fence.polygon", "spec.fence.circle.radius_m",
// "spec.no_fly_zones[2].id") for a fence with no shape, a polygon that is
// not simple or has more than kMaxPrismVertices vertices, a circle off the
// coordinate bounds or without a positive radius, more than kMaxObstacles
// zones, a zone ObstacleFromProto refuses, or a zone id given twice.
[[nodiscard]] absl::Status FillAirspace(const v1::MissionSpec& spec, MissionConfig& c);

// Writes `airspace` into spec->fence and spec->no_fly_zones, in metres.
void WriteAirspace(const Airspace& airspace, v1::MissionSpec* spec);

}  // namespace oaipp::api::internal
