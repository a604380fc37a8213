#!/usr/bin/python3
"""Writes the square-kilometre scenario for large_field_mission: a 1000 x 1000 m
field at 2 m (250,000 cells on the sparse map), 300 prism buildings as a
suburb's map data has them (three in four houses of 7-16 m sides and 3-10 m
height, the rest halls of 15-40 m sides and 6-20 m height; rotated rectangles
and L shapes, none overlapping the start), the ESDF at its default 0.2 m voxel,
and 20 targets, all from one seed.

  /usr/bin/python3 tests/bench/server/square_km.py > /tmp/km.json
  build/tests/bench/server/large_field_mission --scenario=/tmp/km.json --shots=20
"""
import json
import math
import random
import sys


def footprint(rng, cx, cy, a, b, yaw):
    local = [(0, 0), (a, 0), (a, b), (0, b)]
    if rng.random() < 0.4:
        local = [(0, 0), (a, 0), (a, 0.4 * b), (0.4 * a, 0.4 * b), (0.4 * a, b), (0, b)]
    c, s = math.cos(yaw), math.sin(yaw)
    xy = []
    for x, y in local:
        x, y = x - a / 2, y - b / 2
        xy += [round(cx + c * x - s * y, 2), round(cy + s * x + c * y, 2)]
    return xy


def main():
    rng = random.Random(11)
    obstacles = []
    while len(obstacles) < 300:
        house = rng.random() < 0.75
        a, b = (rng.uniform(7, 16), rng.uniform(7, 16)) if house else (rng.uniform(15, 40), rng.uniform(15, 40))
        h = rng.uniform(3, 10) if house else rng.uniform(6, 20)
        cx, cy = rng.uniform(-480, 480), rng.uniform(-480, 480)
        if math.hypot(cx, cy) < 40:
            continue  # the start stays clear
        obstacles.append({"id": f"b{len(obstacles) + 1}",
                          "prism": {"footprint": {"xy_m": footprint(rng, cx, cy, a, b, rng.uniform(0, math.pi))},
                                    "base_m": 0, "top_m": round(h, 2)}})
    targets = []
    for t in range(20):
        x, y = rng.randint(-490, 488), rng.randint(-490, 488)
        targets.append({"id": f"p{t + 1}", "x_min_m": x, "y_min_m": y, "x_max_m": x + 1, "y_max_m": y + 2})
    scenario = {
        "name": "square-km",
        "mission": {
            "preset": "paper",
            "field": {"x_min_m": -500, "y_min_m": -500, "x_max_m": 500, "y_max_m": 500, "resolution_m": 2},
            "flight": {"max_altitude_m": 40},
            "obstacles": obstacles,
            "start": {"position_m": {"x": 0, "y": 0, "z": 30}},
            "budget_s": 1000,
            "planner": {"kind": "PLANNER_KIND_OAIPP", "seed": 1},
        },
        "targets": targets,
        "detector": {"p_max": 0.95, "h_best_m": 10, "width_m": 7, "fp_per_image_at_10m": 0.3},
        "seed": 1,
    }
    json.dump(scenario, sys.stdout, indent=1)


if __name__ == "__main__":
    main()
