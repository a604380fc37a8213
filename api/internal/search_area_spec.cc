#include "api/internal/search_area_spec.h"

#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "api/search_area.h"
#include "core/common/status_macros.h"

namespace oaipp::api::internal {
namespace {

absl::StatusOr<std::vector<Vec2>> RingFromProto(const v1::Ring& r, const std::string& field) {
  if (r.xy_m_size() % 2 != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ".xy_m: ", r.xy_m_size(), " values; x and y come in pairs"));
  }
  std::vector<Vec2> points;
  points.reserve(static_cast<std::size_t>(r.xy_m_size() / 2));
  for (int i = 0; i + 1 < r.xy_m_size(); i += 2) points.emplace_back(r.xy_m(i), r.xy_m(i + 1));
  return points;
}

void RingToProto(const std::vector<Vec2>& ring, v1::Ring* out) {
  for (const Vec2& v : ring) {
    out->add_xy_m(v.x());
    out->add_xy_m(v.y());
  }
}

}  // namespace

absl::Status FillSearchAreas(const google::protobuf::RepeatedPtrField<v1::AreaPolygon>& areas,
                             MissionConfig& c) {
  if (areas.empty()) return absl::OkStatus();
  std::int64_t values = 0;
  for (const v1::AreaPolygon& polygon : areas) {
    values += polygon.outer().xy_m_size();
    for (const v1::Ring& hole : polygon.holes()) values += hole.xy_m_size();
  }
  if (values > 2 * static_cast<std::int64_t>(kMaxAreaVertices)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "spec.search_areas: ", values / 2, " vertices in all, more than ", kMaxAreaVertices));
  }
  std::vector<AreaPolygon> polygons;
  polygons.reserve(static_cast<std::size_t>(areas.size()));
  for (int i = 0; i < areas.size(); ++i) {
    const std::string field = absl::StrCat("spec.search_areas[", i, "]");
    AreaPolygon polygon;
    OAIPP_ASSIGN_OR_RETURN(polygon.outer_m, RingFromProto(areas.Get(i).outer(), field + ".outer"));
    for (int h = 0; h < areas.Get(i).holes_size(); ++h) {
      OAIPP_ASSIGN_OR_RETURN(
          std::vector<Vec2> hole,
          RingFromProto(areas.Get(i).holes(h), absl::StrCat(field, ".holes[", h, "]")));
      polygon.holes_m.push_back(std::move(hole));
    }
    polygons.push_back(std::move(polygon));
  }
  OAIPP_RETURN_IF_ERROR(ValidateSearchArea(polygons, "spec.search_areas"));
  OAIPP_ASSIGN_OR_RETURN(const FieldGrid grid, c.MakeGrid());
  OAIPP_ASSIGN_OR_RETURN(std::vector<std::uint8_t> mask, SearchAreaMask(polygons, grid));
  if (std::find(mask.begin(), mask.end(), std::uint8_t{1}) == mask.end()) {
    return absl::InvalidArgumentError(
        "spec.search_areas: holds the centre of no cell of the field (spec.field)");
  }
  c.search_area = std::make_shared<const SearchArea>(
      SearchArea{.polygons = std::move(polygons), .mask = std::move(mask)});
  return absl::OkStatus();
}

void WriteSearchAreas(std::span<const AreaPolygon> areas, v1::MissionSpec* spec) {
  for (const AreaPolygon& polygon : areas) {
    v1::AreaPolygon& out = *spec->add_search_areas();
    RingToProto(polygon.outer_m, out.mutable_outer());
    for (const std::vector<Vec2>& hole : polygon.holes_m) RingToProto(hole, out.add_holes());
  }
}

}  // namespace oaipp::api::internal
