#!/usr/bin/python3
"""Writes E6's large-field scenarios (docs/experiments.md): by default
e6.json, a 300 x 300 m field at 1 m (90,000 cells, the sparse map), 50
buildings of 8-25 m sides and 6-35 m heights, 20 people of 1 x 2 m in the
open, the UAV starting over the centre. Seeded: the same arguments write
the same file.

    client/scenarios/make_e6.py > client/scenarios/e6.json
    client/scenarios/make_e6.py --name e6-km2 --half_m 500 --resolution_m 2 \
        --buildings 400 --people 60 --esdf_voxel_m 1 --budget_s 600 > client/scenarios/e6-km2.json
    client/scenarios/make_e6.py --name e6-team4 --team 4 > client/scenarios/e6-team4.json

With --team N the start becomes a team of N UAVs (uav-1 .. uav-N) on a ring
around it, 10 m up, in the open square the buildings keep clear of.
"""
import math
import argparse
import json
import random

def overlaps(a, b, gap):
    """Axis-aligned rectangles (x0, y0, x1, y1) closer than gap."""
    return not (a[2] + gap <= b[0] or b[2] + gap <= a[0] or a[3] + gap <= b[1] or b[3] + gap <= a[1])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--name", default="e6")
    parser.add_argument("--seed", type=int, default=6)
    parser.add_argument("--half_m", type=float, default=150.0, help="the field is [-half, half]^2")
    parser.add_argument("--resolution_m", type=float, default=1.0)
    parser.add_argument("--esdf_voxel_m", type=float, default=0.5)
    parser.add_argument("--buildings", type=int, default=50)
    parser.add_argument("--people", type=int, default=20)
    parser.add_argument("--budget_s", type=float, default=1000.0)
    parser.add_argument("--team", type=int, default=0, help="UAVs on a ring around the start; 0: one UAV")
    args = parser.parse_args()
    HALF = args.half_m
    rng = random.Random(args.seed)
    start = (0.0, 0.0)
    rects = []
    obstacles = []
    while len(obstacles) < args.buildings:
        sx, sy = rng.uniform(8, 25), rng.uniform(8, 25)
        cx, cy = rng.uniform(-HALF + sx / 2, HALF - sx / 2), rng.uniform(-HALF + sy / 2, HALF - sy / 2)
        height = rng.uniform(6, 35)
        # Whole decimetres, so that the file reads well.
        sx, sy, cx, cy, height = (round(v, 1) for v in (sx, sy, cx, cy, height))
        r = (cx - sx / 2, cy - sy / 2, cx + sx / 2, cy + sy / 2)
        if any(overlaps(r, o, 4.0) for o in rects) or overlaps(r, (-15, -15, 15, 15), 0.0):
            continue
        rects.append(r)
        obstacles.append({"id": f"b{len(obstacles) + 1}",
                          "box": {"centre_m": {"x": cx, "y": cy, "z": height / 2},
                                  "size_m": {"x": sx, "y": sy, "z": height}}})
    targets = []
    while len(targets) < args.people:
        # 1 x 2 m, lying either way, on whole metres.
        w, h = (1, 2) if rng.random() < 0.5 else (2, 1)
        x0, y0 = rng.randint(-int(HALF), int(HALF) - w), rng.randint(-int(HALF), int(HALF) - h)
        r = (x0, y0, x0 + w, y0 + h)
        if any(overlaps(r, o, 2.0) for o in rects):
            continue
        rects.append(r)
        targets.append({"id": f"p{len(targets) + 1}", "x_min_m": x0, "y_min_m": y0,
                        "x_max_m": x0 + w, "y_max_m": y0 + h})
    scenario = {
        "name": args.name,
        "mission": {
            "preset": "paper",
            "field": {"x_min_m": -HALF, "y_min_m": -HALF, "x_max_m": HALF, "y_max_m": HALF,
                      "resolution_m": args.resolution_m},
            "flight": {"max_altitude_m": 40, "esdf_voxel_m": args.esdf_voxel_m},
            "obstacles": obstacles,
            "start": {"position_m": {"x": start[0], "y": start[1], "z": 10}},
            "budget_s": args.budget_s,
            "planner": {"kind": "PLANNER_KIND_OAIPP", "seed": 1},
        },
        "targets": targets,
        "detector": {"p_max": 0.95, "h_best_m": 10, "width_m": 7, "fp_per_image_at_10m": 0.3},
        "seed": 1,
    }
    if args.team > 0:
        # Neighbours on the ring at least 4.5 m apart (min_separation_m is 4).
        radius = max(5.0, 4.5 / (2 * math.sin(math.pi / args.team))) if args.team > 1 else 0.0
        if radius > 14.0:
            parser.error("--team: too many UAVs for the open square around the start")
        del scenario["mission"]["start"]
        scenario["mission"]["team"] = [
            {"uav_id": f"uav-{k + 1}",
             "start": {"position_m": {"x": round(start[0] + radius * math.cos(2 * math.pi * k / args.team), 1) + 0.0,
                                      "y": round(start[1] + radius * math.sin(2 * math.pi * k / args.team), 1) + 0.0,
                                      "z": 10}}}
            for k in range(args.team)]
    print(json.dumps(scenario, indent=1))


if __name__ == "__main__":
    main()
