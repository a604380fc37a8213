#include "api/search_area.h"

#include <geos_c.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/string_view.h"
#include "api/geos_context.h"
#include "api/limits.h"
#include "core/common/field_error.h"

namespace oaipp::api {
namespace {

// A GEOS context (api/geos_context.h) with the builders of search areas.
class Geos : public GeosContext {
 public:
  // A closed ring through `ring` (its first vertex repeated at the end).
  [[nodiscard]] absl::StatusOr<Ptr> LinearRing(std::span<const Vec2> ring) const {
    std::vector<double> xy;
    xy.reserve(2 * ring.size() + 2);
    for (const Vec2& p : ring) {
      xy.push_back(p.x());
      xy.push_back(p.y());
    }
    xy.push_back(ring.front().x());
    xy.push_back(ring.front().y());
    GEOSCoordSequence* seq = GEOSCoordSeq_copyFromBuffer_r(
        ctx(), xy.data(), static_cast<unsigned>(ring.size() + 1), /*hasZ=*/0, /*hasM=*/0);
    if (seq == nullptr) return Failure("coordinate sequence");
    GEOSGeometry* g = GEOSGeom_createLinearRing_r(ctx(), seq);  // takes seq, even on failure
    if (g == nullptr) return Failure("linear ring");
    return Own(g);
  }

  // The polygon with shell `shell` and holes `holes`, which it takes.
  [[nodiscard]] absl::StatusOr<Ptr> Polygon(Ptr shell, std::vector<Ptr> holes) const {
    std::vector<GEOSGeometry*> raw;
    raw.reserve(holes.size());
    for (Ptr& h : holes) raw.push_back(h.release());
    GEOSGeometry* g =
        GEOSGeom_createPolygon_r(ctx(), shell.get(), raw.data(), static_cast<unsigned>(raw.size()));
    if (g == nullptr) {
      for (GEOSGeometry* h : raw) GEOSGeom_destroy_r(ctx(), h);
      return Failure("polygon");
    }
    shell.release();  // owned by g now
    return Own(g);
  }

  [[nodiscard]] absl::StatusOr<Ptr> Clone(const GEOSGeometry* g) const {
    GEOSGeometry* copy = GEOSGeom_clone_r(ctx(), g);
    if (copy == nullptr) return Failure("clone");
    return Own(copy);
  }
};

// What GEOSisValidDetail_r found: its reason (GEOS's fixed text, never
// input) and where.
struct Invalidity {
  std::string reason;
  Vec2 where_W = Vec2::Zero();
};

// What is wrong with `g` by OGC's rules (no GEOS flags); an empty reason
// when nothing is.
absl::StatusOr<Invalidity> FindInvalidity(const Geos& geos, const GEOSGeometry* g) {
  GEOSContextHandle_t ctx = geos.ctx();
  char* reason = nullptr;
  GEOSGeometry* location = nullptr;
  const char valid = GEOSisValidDetail_r(ctx, g, /*flags=*/0, &reason, &location);
  const Geos::Ptr location_owner = geos.Own(location);
  Invalidity out;
  if (reason != nullptr) {
    out.reason = reason;
    GEOSFree_r(ctx, reason);
  }
  if (valid == 2) return geos.Failure("validity");
  if (valid == 1) return Invalidity{};
  if (location != nullptr) {
    double x = 0.0;
    double y = 0.0;
    if (GEOSGeomGetX_r(ctx, location, &x) == 1 && GEOSGeomGetY_r(ctx, location, &y) == 1) {
      out.where_W = Vec2(x, y);
    }
  }
  if (out.reason.empty()) out.reason = "invalid";
  return out;
}

// " near (x, y) m": one location, to the centimetre.
std::string Near(const Vec2& p_W) {
  return absl::StrFormat(" near (%.2f, %.2f) m", p_W.x(), p_W.y());
}

absl::Status Refuse(std::string format, std::vector<std::string> fields) {
  return FieldError(absl::StatusCode::kInvalidArgument, std::move(format), std::move(fields));
}

// The API path of ring r of area i: r = 0 the outer ring, r = j + 1 hole j.
std::string RingField(const std::string& field, std::size_t i, std::size_t r) {
  return r == 0 ? absl::StrCat(field, "[", i, "].outer")
                : absl::StrCat(field, "[", i, "].holes[", r - 1, "]");
}

// Checks that need no GEOS: size, finiteness, range, distinct vertices.
absl::Status CheckRingVertices(std::span<const Vec2> ring, const std::string& ring_field) {
  for (std::size_t k = 0; k < ring.size(); ++k) {
    if (!AllFinite(ring[k])) {
      return Refuse(absl::StrCat("$0: vertex ", k, " is not finite"), {ring_field});
    }
    if (std::abs(ring[k].x()) > kMaxCoordinateM || std::abs(ring[k].y()) > kMaxCoordinateM) {
      return Refuse(absl::StrCat("$0: vertex ", k, " is more than ", kMaxCoordinateM / 1000.0,
                                 " km from the origin along an axis"),
                    {ring_field});
    }
  }
  std::vector<std::pair<double, double>> distinct;
  distinct.reserve(ring.size());
  for (const Vec2& p : ring) distinct.emplace_back(p.x(), p.y());
  std::sort(distinct.begin(), distinct.end());
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  if (distinct.size() < 3) {
    return Refuse(absl::StrCat("$0: needs at least 3 distinct vertices, got ", distinct.size()),
                  {ring_field});
  }
  return absl::OkStatus();
}

// Names what GEOS found wrong with polygon i once each of its rings is
// known to be simple: which rings meet at `bad.where_W` decides the field.
absl::Status DescribePolygonInvalidity(const Geos& geos, const std::string& field, std::size_t i,
                                       const std::vector<Geos::Ptr>& ring_polygons,
                                       const Invalidity& bad) {
  GEOSContextHandle_t ctx = geos.ctx();
  const std::string near = Near(bad.where_W);
  const Geos::Ptr point =
      geos.Own(GEOSGeom_createPointFromXY_r(ctx, bad.where_W.x(), bad.where_W.y()));
  if (point == nullptr) return geos.Failure("point");
  // Distance from the location to each ring, and whether each ring's
  // polygon covers it.
  std::vector<double> distance_m(ring_polygons.size());
  std::vector<char> covers(ring_polygons.size());
  for (std::size_t r = 0; r < ring_polygons.size(); ++r) {
    const GEOSGeometry* ring = GEOSGetExteriorRing_r(ctx, ring_polygons[r].get());
    if (ring == nullptr || GEOSDistance_r(ctx, ring, point.get(), &distance_m[r]) == 0) {
      return geos.Failure("distance");
    }
    covers[r] = GEOSCovers_r(ctx, ring_polygons[r].get(), point.get());
    if (covers[r] == 2) return geos.Failure("covers");
  }
  // The two rings nearest the location (GEOS reports a vertex or a crossing
  // of the rings at fault, up to round-off).
  std::vector<std::size_t> order(ring_polygons.size());
  for (std::size_t r = 0; r < order.size(); ++r) order[r] = r;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return distance_m[a] < distance_m[b]; });
  const std::size_t nearest = order[0];
  const std::string area_field = absl::StrCat(field, "[", i, "]");

  if (bad.reason == "Hole lies outside shell" && nearest != 0) {
    return Refuse("$0: lies outside the outer ring" + near, {RingField(field, i, nearest)});
  }
  if (bad.reason == "Holes are nested" && nearest != 0) {
    // The location is on the inner hole; the other is a hole covering it.
    for (std::size_t r = 1; r < ring_polygons.size(); ++r) {
      if (r != nearest && covers[r] == 1) {
        return Refuse("$0: overlaps $1" + near, {RingField(field, i, std::max(r, nearest)),
                                                 RingField(field, i, std::min(r, nearest))});
      }
    }
  }
  if (absl::StrContains(bad.reason, "Self-intersection") && order.size() >= 2) {
    const std::size_t a = std::min(order[0], order[1]);
    const std::size_t b = std::max(order[0], order[1]);
    if (a == 0) {
      return Refuse("$0: crosses or runs along the outer ring" + near, {RingField(field, i, b)});
    }
    return Refuse("$0: overlaps $1" + near, {RingField(field, i, b), RingField(field, i, a)});
  }
  if (bad.reason == "Interior is disconnected") {
    return Refuse("$0: its holes cut it into pieces" + near, {area_field});
  }
  // No other reason is expected once the rings are simple and closed; say
  // where, in GEOS's words (fixed text, not input).
  return Refuse(
      absl::StrCat("$0: not a valid polygon (", EscapeForFieldError(bad.reason), ")", near),
      {area_field});
}

// The polygons of `areas`, each valid, or the first error naming its field.
absl::StatusOr<std::vector<Geos::Ptr>> BuildPolygons(const Geos& geos,
                                                     std::span<const AreaPolygon> areas,
                                                     const std::string& field) {
  // Bound the work before any of it: count first.
  std::size_t total = 0;
  for (const AreaPolygon& area : areas) {
    total += area.outer_m.size();
    for (const std::vector<Vec2>& hole : area.holes_m) total += hole.size();
  }
  if (total > static_cast<std::size_t>(kMaxAreaVertices)) {
    return Refuse(absl::StrCat("$0: ", total, " vertices in all, more than ", kMaxAreaVertices),
                  {field});
  }
  for (std::size_t i = 0; i < areas.size(); ++i) {
    const AreaPolygon& area = areas[i];
    if (absl::Status s = CheckRingVertices(area.outer_m, RingField(field, i, 0)); !s.ok()) return s;
    for (std::size_t j = 0; j < area.holes_m.size(); ++j) {
      if (absl::Status s = CheckRingVertices(area.holes_m[j], RingField(field, i, j + 1));
          !s.ok()) {
        return s;
      }
    }
  }

  std::vector<Geos::Ptr> polygons;
  polygons.reserve(areas.size());
  for (std::size_t i = 0; i < areas.size(); ++i) {
    const AreaPolygon& area = areas[i];
    // Each ring alone, as the shell of a polygon: a ring that crosses or
    // touches itself is named here.
    std::vector<Geos::Ptr> ring_polygons;
    ring_polygons.reserve(area.holes_m.size() + 1);
    for (std::size_t r = 0; r <= area.holes_m.size(); ++r) {
      const std::span<const Vec2> ring = r == 0 ? area.outer_m : area.holes_m[r - 1];
      absl::StatusOr<Geos::Ptr> linear = geos.LinearRing(ring);
      if (!linear.ok()) return linear.status();
      absl::StatusOr<Invalidity> bad = FindInvalidity(geos, linear->get());
      if (!bad.ok()) return bad.status();
      if (!bad->reason.empty()) {
        return Refuse("$0: self-intersecting" + Near(bad->where_W), {RingField(field, i, r)});
      }
      absl::StatusOr<Geos::Ptr> alone = geos.Polygon(*std::move(linear), {});
      if (!alone.ok()) return alone.status();
      ring_polygons.push_back(*std::move(alone));
    }
    // The rings together: how holes sit in the outer ring and each other.
    std::vector<Geos::Ptr> holes;
    holes.reserve(area.holes_m.size());
    Geos::Ptr shell;
    for (std::size_t r = 0; r < ring_polygons.size(); ++r) {
      absl::StatusOr<Geos::Ptr> ring =
          geos.Clone(GEOSGetExteriorRing_r(geos.ctx(), ring_polygons[r].get()));
      if (!ring.ok()) return ring.status();
      if (r == 0) {
        shell = *std::move(ring);
      } else {
        holes.push_back(*std::move(ring));
      }
    }
    absl::StatusOr<Geos::Ptr> polygon = geos.Polygon(std::move(shell), std::move(holes));
    if (!polygon.ok()) return polygon.status();
    absl::StatusOr<Invalidity> bad = FindInvalidity(geos, polygon->get());
    if (!bad.ok()) return bad.status();
    if (!bad->reason.empty()) return DescribePolygonInvalidity(geos, field, i, ring_polygons, *bad);
    polygons.push_back(*std::move(polygon));
  }
  return polygons;
}

// The union of `areas`, validated as "search_areas" (an empty geometry for
// none).
absl::StatusOr<Geos::Ptr> Union(const Geos& geos, std::span<const AreaPolygon> areas) {
  absl::StatusOr<std::vector<Geos::Ptr>> polygons = BuildPolygons(geos, areas, "search_areas");
  if (!polygons.ok()) return polygons.status();
  return geos.UnionOf(*std::move(polygons));
}

}  // namespace

absl::Status ValidateSearchArea(std::span<const AreaPolygon> areas, std::string_view field) {
  const Geos geos;
  // Abseil's string_view here is its own type, not std::string_view.
  return BuildPolygons(geos, areas, std::string(field)).status();
}

absl::StatusOr<std::vector<std::uint8_t>> SearchAreaMask(std::span<const AreaPolygon> areas,
                                                         const FieldGrid& grid) {
  std::vector<std::uint8_t> mask(static_cast<std::size_t>(grid.num_cells()), 0);
  const Geos geos;
  absl::StatusOr<Geos::Ptr> united = Union(geos, areas);
  if (!united.ok()) return united.status();
  GEOSContextHandle_t ctx = geos.ctx();
  if (GEOSisEmpty_r(ctx, united->get()) == 1) return mask;
  double x_min = 0.0;
  double y_min = 0.0;
  double x_max = 0.0;
  double y_max = 0.0;
  if (GEOSGeom_getExtent_r(ctx, united->get(), &x_min, &y_min, &x_max, &y_max) == 0) {
    return geos.Failure("extent");
  }
  // Intersects, not Contains: a centre on the boundary is inside.
  const Geos::PreparedPtr prepared = geos.Prepare(united->get());
  if (prepared == nullptr) return geos.Failure("prepare");
  for (int index = 0; index < grid.num_cells(); ++index) {
    const Vec2 c_W = grid.CellCentreXY(index);
    if (c_W.x() < x_min || c_W.x() > x_max || c_W.y() < y_min || c_W.y() > y_max) continue;
    const Geos::Ptr point = geos.Own(GEOSGeom_createPointFromXY_r(ctx, c_W.x(), c_W.y()));
    if (point == nullptr) return geos.Failure("point");
    const char inside = GEOSPreparedIntersects_r(ctx, prepared.get(), point.get());
    if (inside == 2) return geos.Failure("intersects");
    mask[static_cast<std::size_t>(index)] = static_cast<std::uint8_t>(inside);
  }
  return mask;
}

absl::StatusOr<double> SearchAreaSize_m2(std::span<const AreaPolygon> areas) {
  const Geos geos;
  absl::StatusOr<Geos::Ptr> united = Union(geos, areas);
  if (!united.ok()) return united.status();
  double area_m2 = 0.0;
  if (GEOSArea_r(geos.ctx(), united->get(), &area_m2) == 0) return geos.Failure("area");
  return area_m2;
}

}  // namespace oaipp::api
