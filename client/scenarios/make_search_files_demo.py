#!/usr/bin/python3
"""Writes the map-files demo (docs/search-files.md): a 100 x 100 m village
near Zurich as a search team would bring it, and the scenario that reads it.

    client/scenarios/make_search_files_demo.py

writes, beside this script,
    search-files-demo.json                 the scenario (search_files names the files)
    search-files-demo/area.geojson         the search area: concave, with a pond as a hole
    search-files-demo/fence.geojson        the inclusion fence, 1 m inside the field
    search-files-demo/zones.kml            no-fly zones: a helipad and a mast (KML 2.2)
    search-files-demo/buildings.geojson    OSM-tagged footprints (height, building:levels,
                                           or neither), a courtyard, a car park
The geometry is laid out in the mission's local metres (x east, y north from
the geo_origin) and written as WGS84 with the ellipsoid's radii of curvature
at the origin: within a millimetre over 100 m. Seeded: the same script writes
the same files. Standard library only.
"""
import json
import math
import os
import random

ORIGIN = (47.397742, 8.545594, 488.0)  # latitude, longitude (deg), altitude (m AMSL)
HALF = 50.0                            # the field is [-HALF, HALF]^2 m
START = (0.0, 0.0, 10.0)
POND = [(-32 + 6 * math.cos(a), -30 + 6 * math.sin(a)) for a in
        [2 * math.pi * k / 8 for k in range(8)]]
HELIPAD = [(30.0, 30.0), (42.0, 30.0), (42.0, 42.0), (30.0, 42.0)]
MAST = (-40.0, 40.0, 4.0)              # x, y, radius (m)
AREA = [(-48, -48), (48, -48), (48, 22), (12, 22), (12, 48), (-48, 48)]  # concave at (12, 22)
SCHOOL = [(-20.0, 28.0), (-8.0, 28.0), (-8.0, 40.0), (-20.0, 40.0)]    # with a courtyard
YARD = [(-16.0, 32.0), (-12.0, 32.0), (-12.0, 36.0), (-16.0, 36.0)]


def to_lat_lon(x, y):
    """Local east/north metres -> (lat, lon) degrees, WGS84."""
    a, f = 6378137.0, 1 / 298.257223563
    e2 = f * (2 - f)
    phi = math.radians(ORIGIN[0])
    w = 1 - e2 * math.sin(phi) ** 2
    m = a * (1 - e2) / w ** 1.5   # meridian radius of curvature
    n = a / math.sqrt(w)          # prime vertical radius of curvature
    return (ORIGIN[0] + math.degrees(y / m), ORIGIN[1] + math.degrees(x / (n * math.cos(phi))))


def lon_lat_ring(points):
    """A closed GeoJSON ring, [lon, lat] to 1e-8 deg (about 1 mm)."""
    ring = []
    for x, y in list(points) + [points[0]]:
        lat, lon = to_lat_lon(x, y)
        ring.append([round(lon, 8), round(lat, 8)])
    return ring


def kml_coordinates(points):
    out = []
    for x, y in list(points) + [points[0]]:
        lat, lon = to_lat_lon(x, y)
        out.append("%.8f,%.8f,0" % (lon, lat))
    return " ".join(out)


def footprint(cx, cy, sx, sy, yaw, l_shape):
    """A rectangle (or an L cut from it) turned by yaw about its centre."""
    if l_shape:
        local = [(-sx / 2, -sy / 2), (sx / 2, -sy / 2), (sx / 2, 0), (0, 0), (0, sy / 2),
                 (-sx / 2, sy / 2)]
    else:
        local = [(-sx / 2, -sy / 2), (sx / 2, -sy / 2), (sx / 2, sy / 2), (-sx / 2, sy / 2)]
    c, s = math.cos(yaw), math.sin(yaw)
    return [(round(cx + c * u - s * v, 2), round(cy + s * u + c * v, 2)) for u, v in local]


def near(points, x, y, gap):
    """Whether (x, y) is within gap of the bounding box of points."""
    xs, ys = [p[0] for p in points], [p[1] for p in points]
    return min(xs) - gap <= x <= max(xs) + gap and min(ys) - gap <= y <= max(ys) + gap


def main():
    rng = random.Random(7)
    here = os.path.dirname(os.path.abspath(__file__))
    folder = os.path.join(here, "search-files-demo")
    os.makedirs(folder, exist_ok=True)

    # Lots of 11 m on a grid; the square around the start, the pond, the
    # helipad, the mast and the school's block stay open.
    features, boxes = [], []
    pitch = 11.0
    centres = [-44.0 + pitch * i for i in range(9)]
    number = 0
    for cy in centres:
        for cx in centres:
            if abs(cx) < 12 and abs(cy) < 12:
                continue
            if (near(POND, cx, cy, 6) or near(HELIPAD, cx, cy, 6) or near(SCHOOL, cx, cy, 6)
                    or math.hypot(cx - MAST[0], cy - MAST[1]) < 12):
                continue
            number += 1
            sx, sy = rng.uniform(4.5, 7), rng.uniform(4.5, 7)
            yaw = math.radians(rng.uniform(-15, 15))
            ring = footprint(cx + rng.uniform(-0.5, 0.5), cy + rng.uniform(-0.5, 0.5), sx, sy, yaw,
                             l_shape=number % 7 == 0)
            tags = {"@id": "way/%d" % (900000 + number), "building": rng.choice(
                ["yes", "house", "residential", "garage", "shed"])}
            kind = number % 4
            if kind == 0:
                tags["height"] = "%.1f m" % rng.uniform(4, 16)
            elif kind == 1:
                tags["height"] = "%d" % rng.randint(4, 16)
            elif kind == 2:
                tags["building:levels"] = str(rng.randint(1, 5))
            elif number % 8 != 3:
                tags["building:levels"] = str(rng.randint(1, 3))
            # else: no height tag: the importer's default (10 m), listed
            rings = [lon_lat_ring(ring)]
            features.append({"type": "Feature", "properties": tags,
                             "geometry": {"type": "Polygon", "coordinates": rings}})
            boxes.append(ring)
    # A block with a courtyard (an OSM multipolygon), and a car park that
    # is not a building.
    features.append({"type": "Feature",
                     "properties": {"@id": "relation/77", "building": "school", "height": "9"},
                     "geometry": {"type": "MultiPolygon",
                                  "coordinates": [[lon_lat_ring(SCHOOL), lon_lat_ring(YARD)]]}})
    boxes.append(SCHOOL)
    features.append({"type": "Feature", "properties": {"@id": "way/88", "amenity": "parking"},
                     "geometry": {"type": "Polygon",
                                  "coordinates": [lon_lat_ring([(2, -40), (10, -40), (10, -34), (2, -34)])]}})
    write_json(os.path.join(folder, "buildings.geojson"),
               {"type": "FeatureCollection", "features": features})

    write_json(os.path.join(folder, "area.geojson"), {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"name": "search area, pond excluded"},
         "geometry": {"type": "Polygon", "coordinates": [lon_lat_ring(AREA), lon_lat_ring(POND)]}}]})
    fence = [(-49, -49), (49, -49), (49, 49), (-49, 49)]
    write_json(os.path.join(folder, "fence.geojson"), {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"name": "fence"},
         "geometry": {"type": "Polygon", "coordinates": [lon_lat_ring(fence)]}}]})
    mast_lat, mast_lon = to_lat_lon(MAST[0], MAST[1])
    with open(os.path.join(folder, "zones.kml"), "w") as out:
        out.write("""<?xml version="1.0" encoding="UTF-8"?>
<kml xmlns="http://www.opengis.net/kml/2.2">
<Document>
<name>search-files-demo no-fly zones</name>
<Placemark><name>helipad</name>
<ExtendedData><Data name="floor_m"><value>0</value></Data><Data name="ceiling_m"><value>60</value></Data></ExtendedData>
<Polygon><outerBoundaryIs><LinearRing><coordinates>%s</coordinates></LinearRing></outerBoundaryIs></Polygon>
</Placemark>
<Placemark><name>radio mast</name>
<ExtendedData><Data name="radius_m"><value>%g</value></Data><Data name="ceiling_m"><value>50</value></Data></ExtendedData>
<Point><coordinates>%.8f,%.8f,0</coordinates></Point>
</Placemark>
</Document>
</kml>
""" % (kml_coordinates(HELIPAD), MAST[2], mast_lon, mast_lat))

    # People in the open: inside the area, out of the pond, 2 m from any
    # building and zone.
    def open_ground(x, y):
        if not inside(AREA, x, y) or near(POND, x, y, 2) or near(HELIPAD, x, y, 2):
            return False
        if math.hypot(x - MAST[0], y - MAST[1]) < MAST[2] + 2:
            return False
        return not any(near(b, x, y, 2.5) for b in boxes)
    targets = []
    while len(targets) < 8:
        x, y = round(rng.uniform(-46, 46), 1), round(rng.uniform(-46, 46), 1)
        if open_ground(x, y) and open_ground(x, y + 2):
            targets.append({"id": "p%d" % (len(targets) + 1), "x_min_m": round(x - 0.375, 3),
                            "y_min_m": y, "x_max_m": round(x + 0.375, 3),
                            "y_max_m": round(y + 2, 3)})
    scenario = {
        "name": "search-files-demo",
        "mission": {
            "preset": "paper",
            "geo_origin": {"latitude_deg": ORIGIN[0], "longitude_deg": ORIGIN[1],
                           "altitude_m": ORIGIN[2]},
            "field": {"x_min_m": -HALF, "y_min_m": -HALF, "x_max_m": HALF, "y_max_m": HALF,
                      "resolution_m": 2.0},
            "flight": {"max_altitude_m": 26, "esdf_voxel_m": 0.5},
            "start": {"position_m": {"x": START[0], "y": START[1], "z": START[2]}},
            "budget_s": 150,
            "planner": {"kind": "PLANNER_KIND_OAIPP", "seed": 1},
        },
        "search_files": {
            "area": "search-files-demo/area.geojson",
            "fence": "search-files-demo/fence.geojson",
            "no_fly_zones": "search-files-demo/zones.kml",
            "buildings": "search-files-demo/buildings.geojson",
        },
        "targets": targets,
        "detector": {"p_max": 0.95, "h_best_m": 10, "width_m": 7, "fp_per_image_at_10m": 0.3},
        "seed": 1,
    }
    write_json(os.path.join(here, "search-files-demo.json"), scenario, indent=1)


def inside(polygon, x, y):
    """Even-odd rule."""
    result = False
    for i in range(len(polygon)):
        (x0, y0), (x1, y1) = polygon[i], polygon[i - 1]
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            result = not result
    return result


def write_json(path, value, indent=None):
    """JSON; a FeatureCollection one feature a line."""
    with open(path, "w") as out:
        if value.get("type") == "FeatureCollection":
            out.write('{"type": "FeatureCollection", "features": [\n')
            out.write(",\n".join(json.dumps(f) for f in value["features"]))
            out.write("\n]}\n")
        else:
            json.dump(value, out, indent=indent)
            out.write("\n")


if __name__ == "__main__":
    main()
