#!/usr/bin/python3
"""Writes prior-demo.json and prior-demo.npy: a search on the paper's 30 x 30 m
field (40 x 40 cells of 0.75 m) from a real lost-person map, SAREnv dataset
1's medium crop (120 x 120 cells of 30 m, 3.6 km across), summed 3 x 3 into
40 x 40 and shrunk onto the field. The map is given as relative likelihood:
the scenario scales it so that the most likely cell has a label mean of 0.5.
Three people stand where the map says people are (cells drawn with the map's
probabilities, seeded), and two towers stand in the way. Seeded: the same
arguments write the same files.

    /usr/bin/python3 client/scenarios/make_prior_demo.py
"""
import argparse
import json
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.join(HERE, "..", "..", "tests", "client", "sarenv", "data", "dataset1_medium.npy")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--people", type=int, default=3)
    args = parser.parse_args()
    source = np.load(SOURCE)  # row 0 is the south edge, as the field's rows
    n = 40
    block = source.shape[0] // n
    prior = source[: n * block, : n * block].reshape(n, block, n, block).sum(axis=(1, 3))
    np.save(os.path.join(HERE, "prior-demo.npy"), prior.astype("<f8"))

    rng = np.random.default_rng(args.seed)
    cells = rng.choice(n * n, size=args.people, replace=False, p=(prior / prior.sum()).ravel())
    resolution, x0 = 0.75, -15.0
    targets = []
    for k, cell in enumerate(sorted(int(c) for c in cells)):
        row, col = divmod(cell, n)
        x, y = x0 + resolution * (col + 0.5), x0 + resolution * (row + 0.5)
        targets.append({"id": f"p{k + 1}", "x_min_m": x - 0.375, "y_min_m": y - 1.0,
                        "x_max_m": x + 0.375, "y_max_m": y + 1.0})

    def tower(name, x, y, sx, sy, h):
        return {"id": name, "box": {"centre_m": {"x": x, "y": y, "z": h / 2},
                                    "size_m": {"x": sx, "y": sy, "z": h}}}

    scenario = {
        "name": "prior-demo",
        "mission": {
            "preset": "paper",
            "obstacles": [tower("tower-a", 3, 4, 3, 3, 24), tower("tower-b", -8, -2, 3, 5, 18)],
            "start": {"position_m": {"x": 12, "y": -12, "z": 8}},
            "budget_s": 150,
            "planner": {"kind": "PLANNER_KIND_OAIPP", "seed": 1},
        },
        "priorMapFile": {"path": "prior-demo.npy", "units": "PRIOR_MAP_UNITS_LABEL_MEAN",
                         "scale": 0.5 / float(prior.max())},
        "targets": targets,
        "detector": {"p_max": 0.95, "h_best_m": 10, "width_m": 7, "fp_per_image_at_10m": 0.3},
        "seed": 1,
    }
    with open(os.path.join(HERE, "prior-demo.json"), "w") as f:
        json.dump(scenario, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
