#!/usr/bin/env python3
"""Mean +- std curves per variant (planner or world) from `oaipp-client eval` trials.csv.

    python3 client/plots/plot_curves.py out/eval/E1/trials.csv rse out/eval/E1/rse.png \
        --paper oaipp=5.17 lawnmower=5.85 random=6.22
"""
import argparse
import csv
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("csv")
    parser.add_argument("column", help="rse, trace, targets_found, ...")
    parser.add_argument("png")
    parser.add_argument("--title", default="")
    parser.add_argument("--paper", nargs="*", default=[],
                        help="variant=value pairs: the paper's value at the end, drawn as markers")
    args = parser.parse_args()

    series = defaultdict(lambda: defaultdict(list))  # variant -> time -> values
    with open(args.csv) as f:
        for row in csv.DictReader(f):
            series[row["variant"]][float(row["time_s"])].append(float(row[args.column]))

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for variant in series:  # in the order the CSV lists them
        times = sorted(series[variant])
        values = [np.array(series[variant][t]) for t in times]
        mean = np.array([v.mean() for v in values])
        std = np.array([v.std(ddof=1) if len(v) > 1 else 0.0 for v in values])
        n = len(values[0])
        line, = ax.plot(times, mean, label=f"{variant} (n={n})")
        ax.fill_between(times, mean - std, mean + std, color=line.get_color(), alpha=0.2)
    end = max(max(s) for s in series.values())
    for pair in args.paper:
        variant, value = pair.split("=")
        ax.plot([end], [float(value)], marker="*", markersize=12, linestyle="none",
                label=f"paper, {variant}: {value}")
    ax.set_xlabel("mission time (s)")
    ax.set_ylabel(args.column)
    ax.set_title(args.title or f"{args.column} over time, mean +- std")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.png, dpi=120)


if __name__ == "__main__":
    main()
