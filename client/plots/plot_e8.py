#!/usr/bin/env python3
"""E8's pictures: per dataset, the lost-person map with OA-IPP's flown paths, a panel per team size.

    python3 client/plots/plot_e8.py out/eval/E8

Reads OUT/paths/N_map.npy + N_map.json (the crop), N_nK_BKkm_OA-IPP.csv (each UAV's path in the
crop's CRS, flown to a budget of B km) and N_nK_BKkm_Greedy.csv, and writes OUT/e8_N.png: the
flight to the smallest budget bold, to the largest thin, Greedy's to the smallest in grey.
"""
import csv
import glob
import json
import os
import re
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def read_paths(path):
    lines = defaultdict(list)
    with open(path) as f:
        for row in csv.DictReader(f):
            lines[row["uav"]].append((float(row["x_m"]), float(row["y_m"])))
    return [np.array(v) for v in lines.values()]


def main():
    out = sys.argv[1]
    maps = sorted(glob.glob(os.path.join(out, "paths", "*_map.npy")),
                  key=lambda p: int(os.path.basename(p).split("_")[0]))
    for npy in maps:
        number = os.path.basename(npy).split("_")[0]
        meta = json.load(open(npy[:-4] + ".json"))
        heat = np.load(npy)
        x0, y0, x1, y1 = meta["bounds"]
        cx, cy = meta["center_x_m"], meta["center_y_m"]
        extent = [(x0 - cx) / 1000, (x1 - cx) / 1000, (y0 - cy) / 1000, (y1 - cy) / 1000]
        runs = defaultdict(dict)  # team size -> budget km -> file
        for p in glob.glob(os.path.join(out, "paths", f"{number}_n*km_OA-IPP.csv")):
            m = re.search(r"_n(\d+)_(\d+)km_", p)
            runs[int(m.group(1))][int(m.group(2))] = p
        if not runs:
            continue
        sizes = sorted(runs)
        fig, axes = plt.subplots(1, len(sizes), figsize=(5.2 * len(sizes), 5.2), squeeze=False)
        shown = np.where(heat > 0, heat, np.nan)
        colours = plt.cm.tab10.colors
        for ax, n in zip(axes[0], sizes):
            ax.imshow(shown, origin="lower", extent=extent, cmap="magma", interpolation="nearest")
            small, large = min(runs[n]), max(runs[n])
            greedy = os.path.join(out, "paths", f"{number}_n{n}_{small}km_Greedy.csv")
            if os.path.exists(greedy):
                for line in read_paths(greedy):
                    ax.plot((line[:, 0] - cx) / 1000, (line[:, 1] - cy) / 1000, color="0.75",
                            lw=0.8)
            for budget, width in ([(large, 0.4)] if large != small else []) + [(small, 1.4)]:
                for k, line in enumerate(read_paths(runs[n][budget])):
                    ax.plot((line[:, 0] - cx) / 1000, (line[:, 1] - cy) / 1000,
                            color=colours[k % 10], lw=width, alpha=0.5 if width < 1 else 1.0)
            ax.plot([0], [0], "wo", ms=5, mec="k")
            title = f"dataset {number}, n = {n}: {small} km bold"
            ax.set_title(title + (f", {large} km thin" if large != small else ""))
            ax.set_xlabel("east of the last known point [km]")
            ax.set_ylabel("north [km]")
        fig.suptitle("OA-IPP's flown paths over the lost-person map (a colour per UAV); grey: Greedy")
        fig.tight_layout()
        fig.savefig(os.path.join(out, f"e8_{number}.png"), dpi=80)
        plt.close(fig)


if __name__ == "__main__":
    main()
