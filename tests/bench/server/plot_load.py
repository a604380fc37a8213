#!/usr/bin/python3
"""Latency percentiles over time from a server_load --json file.

One panel per method (PlanPath, AddMeasurement): the 50th, 90th and 99th
percentile of the calls that started in each window, on a log scale, with
the number of calls per window on a second axis; a last panel shows the
share of its CMA-ES generations each plan ran (shed, or ended by the
latency bound) against when it was asked for. CreateMission (all at the
start) is summed up in the title.

    /usr/bin/python3 tests/bench/server/plot_load.py load.json load.png [--window_s 10]
"""
import argparse
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

METHODS = ("PlanPath", "AddMeasurement")


def percentile(values, q):
    """The q-quantile (0..1) as server_load computes it (nearest rank)."""
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def windows(calls, method, window_s):
    """[(window start, p50, p90, p99, count)] for `method`'s calls."""
    by_window = {}
    for start_s, name, ms, _ok in calls:
        if name == method:
            by_window.setdefault(int(start_s // window_s), []).append(ms)
    rows = []
    for w in sorted(by_window):
        v = by_window[w]
        rows.append((w * window_s, percentile(v, 0.5), percentile(v, 0.9), percentile(v, 0.99), len(v)))
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("json_file")
    parser.add_argument("png_file")
    parser.add_argument("--window_s", type=float, default=10.0)
    args = parser.parse_args()
    if not args.window_s > 0:
        sys.exit("--window_s: must be > 0")
    with open(args.json_file) as f:
        figures = json.load(f)
    run = figures["runs"][0]
    calls = run["calls"]
    fig, axes = plt.subplots(len(METHODS) + 1, 1, figsize=(9, 9), sharex=True)
    for ax, method in zip(axes, METHODS):
        rows = windows(calls, method, args.window_s)
        if not rows:
            ax.set_title(f"{method}: no calls")
            continue
        t = [r[0] + args.window_s / 2 for r in rows]
        for column, label, style in ((1, "p50", "-"), (2, "p90", "--"), (3, "p99", ":")):
            ax.plot(t, [r[column] for r in rows], style, marker="o", markersize=3, label=label)
        ax.set_yscale("log")
        ax.set_ylabel("latency, ms")
        summary = run["methods"][method]
        ax.set_title(f"{method}: {summary['calls']} calls, p50 {summary['p50_ms']:.0f} ms, "
                     f"p99 {summary['p99_ms']:.0f} ms overall")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(loc="upper left")
        counts = ax.twinx()
        counts.bar(t, [r[4] for r in rows], width=args.window_s * 0.8, alpha=0.15, color="grey")
        counts.set_ylabel(f"calls per {args.window_s:g} s")
    # The share of its CMA-ES generations each plan ran (cut by shedding or
    # by the latency bound), against when the plan was asked for.
    plans = [p for m in run["missions"] for p in m["plan_stats"]]
    generations = max(1, figures.get("generations", 45))
    ax = axes[-1]
    for cut, colour, label in ((False, "tab:blue", "whole search or shed"),
                               (True, "tab:red", "ended by the latency bound")):
        chosen = [p for p in plans if (p[6] > 0) == cut]
        ax.plot([p[0] for p in chosen], [min(p[3] / generations, 1.0) for p in chosen], ".",
                markersize=3, alpha=0.5, color=colour, label=f"{label}: {len(chosen)}")
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("generations run / configured")
    ax.set_xlabel("seconds since the load started")
    short = sum(1 for p in plans if p[3] < generations)
    ax.set_title(f"plans that ran fewer than {generations} generations: {short} of {len(plans)}")
    ax.legend(loc="lower right")
    ax.grid(True, alpha=0.3)
    create = run["methods"].get("CreateMission", {"p50_ms": 0, "p99_ms": 0})
    fig.suptitle(f"{figures['missions']} E1 missions of {figures['budget_s']:g} s ({run['pace']}), "
                 f"{figures['planning_threads']} planning threads: wall {run['wall_s']:.1f} s, "
                 f"RSE {run['rse_mean']:.2f} ± {run['rse_stderr']:.2f}\n"
                 f"CreateMission p50 {create['p50_ms']:.0f} ms, p99 {create['p99_ms']:.0f} ms")
    fig.tight_layout()
    fig.savefig(args.png_file, dpi=90)
    print(f"wrote {args.png_file}")


if __name__ == "__main__":
    main()
