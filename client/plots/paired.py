#!/usr/bin/python3
"""Compares two variants of an eval run seed by seed: for each time and
column, each variant's mean and standard error, and the paired difference
(A - B over the seeds both flew) with its standard error and how many
seeds it was positive, negative or zero on. Several trials.csv files (for
example two runs over different seeds) are read as one.

    client/plots/paired.py --a oaipp_confirm --b lawnmower --times 500,1000 \\
        --columns targets_found,rse RUN1/trials.csv RUN2/trials.csv

A trial's value at time t is its last record at or before t.
"""
import argparse
import collections
import csv
import math
import statistics
import sys


def mean_se(values):
    m = statistics.fmean(values)
    if len(values) < 2:
        return m, float("nan")
    return m, statistics.stdev(values) / math.sqrt(len(values))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trials", nargs="+", help="trials.csv files written by oaipp-client eval")
    parser.add_argument("--a", required=True, help="variant A")
    parser.add_argument("--b", required=True, help="variant B")
    parser.add_argument("--times", default="", help="comma-separated seconds; default: the last")
    parser.add_argument("--columns", default="rse", help="comma-separated trials.csv columns")
    args = parser.parse_args()

    records = collections.defaultdict(dict)  # (variant, trial) -> {time: row}
    for path in args.trials:
        seen_in = set()  # this file's trials
        with open(path, newline="") as f:
            for row in csv.DictReader(f):
                key = (row["variant"], int(row["trial"]))
                if key in records and key not in seen_in:
                    sys.exit(f"{path}: {key[0]} trial {key[1]} is in an earlier file too")
                seen_in.add(key)
                records[key][float(row["time_s"])] = row
    seeds = sorted({t for v, t in records if v == args.a} & {t for v, t in records if v == args.b})
    if not seeds:
        sys.exit(f"no trial that both {args.a} and {args.b} flew")
    columns = [c for c in args.columns.split(",") if c]
    last = max(max(rows) for rows in records.values())
    times = [float(t) for t in args.times.split(",") if t] or [last]

    def value(variant, seed, t, column):
        rows = records[(variant, seed)]
        before = [s for s in rows if s <= t + 1e-9]
        if not before:
            sys.exit(f"{variant} trial {seed} has no record at or before {t} s")
        return float(rows[max(before)][column])

    print(f"{len(seeds)} seeds both flew ({seeds[0]} .. {seeds[-1]})")
    print("| column | time s | A mean (SE) | B mean (SE) | A - B paired (SE) | in SE | A above / below / equal |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for column in columns:
        for t in times:
            a = [value(args.a, s, t, column) for s in seeds]
            b = [value(args.b, s, t, column) for s in seeds]
            d = [x - y for x, y in zip(a, b)]
            (ma, sa), (mb, sb), (md, sd) = mean_se(a), mean_se(b), mean_se(d)
            z = md / sd if sd > 0 else float("nan")
            above = sum(x > 0 for x in d)
            below = sum(x < 0 for x in d)
            print(f"| {column} | {t:g} | {ma:.3f} ({sa:.3f}) | {mb:.3f} ({sb:.3f}) | "
                  f"{md:+.3f} ({sd:.3f}) | {z:+.2f} | {above} / {below} / {len(d) - above - below} |")


if __name__ == "__main__":
    main()
