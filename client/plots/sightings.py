#!/usr/bin/python3
"""Where a search spends its looks: a summary of an eval's sightings.csv.

For each variant, two tables:

- looks by camera altitude (2 m bands): how many times a person was in
  view, the share the detector reported, and the detector's p(h) at the
  band's centre (defaults of DetectorParams, or --p_max/--h_best/--width);
- the person each trial settled last: when it was first in view, when the
  map's mean there last crossed 0.5 upwards for good (from the rows'
  mean_after), the looks and misses until then, and the longest time
  between two looks until then (each a mean over the trials). Trials that
  never settle everyone are counted apart.

  /usr/bin/python3 client/plots/sightings.py out/eval/E7/sightings.csv
"""
import argparse
import collections
import csv
import math
import statistics


def detection_probability(h, p_max, h_best, width):
    return p_max * math.exp(-0.5 * ((h - h_best) / width) ** 2)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sightings", help="an eval's sightings.csv")
    parser.add_argument("--p_max", type=float, default=0.95)
    parser.add_argument("--h_best", type=float, default=10.0)
    parser.add_argument("--width", type=float, default=7.0)
    args = parser.parse_args()

    looks = collections.defaultdict(list)  # (variant, trial, target) -> rows
    with open(args.sightings, newline="") as f:
        for row in csv.DictReader(f):
            looks[(row["variant"], int(row["trial"]), row["target"])].append(
                (float(row["time_s"]), float(row["altitude_m"]), int(row["detected"]),
                 float(row["mean_after"])))

    variants = sorted({v for v, _, _ in looks})
    # A person never in view in a trial has no rows there: a trial counts as
    # settling everyone only when every person of the file has settled.
    everyone = {target for _, _, target in looks}
    for variant in variants:
        bands = collections.defaultdict(lambda: [0, 0])
        trials = collections.defaultdict(dict)
        for (v, trial, target), rows in looks.items():
            if v != variant:
                continue
            rows.sort(key=lambda r: r[0])  # stable: same-instant rows keep the fusion order
            for _, h, detected, _ in rows:
                band = 2 * int(h // 2)
                bands[band][0] += 1
                bands[band][1] += detected
            settled = None  # last upward crossing of 0.5 that holds
            for t, _, _, mean in rows:
                if mean >= 0.5 and settled is None:
                    settled = t
                elif mean < 0.5:
                    settled = None
            trials[trial][target] = (settled, rows)

        total = sum(n for n, _ in bands.values())
        print(f"## {variant}\n")
        print("| altitude m | looks | share of looks | reported | p(h) |")
        print("| --- | --- | --- | --- | --- |")
        for band in sorted(bands):
            n, d = bands[band]
            p = detection_probability(band + 1.0, args.p_max, args.h_best, args.width)
            print(f"| {band}-{band + 2} | {n} | {n / total:.2f} | {d / n:.2f} | {p:.2f} |")

        last = []
        unsettled = 0
        for per_target in trials.values():
            if set(per_target) != everyone or any(s is None for s, _ in per_target.values()):
                unsettled += 1
                continue
            target = max(per_target, key=lambda k: per_target[k][0])
            settled, rows = per_target[target]
            before = [r for r in rows if r[0] <= settled]
            times = sorted({r[0] for r in before})
            gaps = [b - a for a, b in zip(times, times[1:])]
            last.append((rows[0][0], settled, len(before), sum(1 for r in before if r[2] == 0),
                         max(gaps, default=0.0), statistics.fmean(r[1] for r in before)))
        print()
        if last:
            mean = [statistics.fmean(x[i] for x in last) for i in range(6)]
            print(f"last person settled (means over {len(last)} trials; {unsettled} never "
                  f"settled everyone): first in view {mean[0]:.1f} s, settled {mean[1]:.1f} s, "
                  f"{mean[2]:.2f} looks, {mean[3]:.2f} misses, longest gap {mean[4]:.1f} s on average, "
                  f"altitude {mean[5]:.1f} m\n")
        else:
            print(f"no trial settled everyone ({unsettled} trials)\n")


if __name__ == "__main__":
    main()
