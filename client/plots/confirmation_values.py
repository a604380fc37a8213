#!/usr/bin/env python3
"""What one more shot is worth to the confirmation term, cell by cell.

Builds the paper's prior on E5's 30 x 30 m field at 0.75 m cells (Matern 3/2,
the published hyper-parameters, no buildings), fuses shots at 11.5 m with the
map's own Kalman update (a detection labels the person's cells 1 and the rest
of the footprint 0; a miss labels the whole footprint 0), and prints, for a
cell of a person detected once and missed once, a cell never seen and a cell
seen once and empty: its mean, its variance and the expected reduction of the
probability that it lies on the other side of 0.5 from its mean after one
more shot from 11.5 m (docs/method.md section 6.4), by Monte Carlo over the
shot, independently of the C++ code.

    /usr/bin/python3 client/plots/confirmation_values.py
"""
import math

import numpy as np

SIDE_M, CELL_M = 30.0, 0.75
LENGTH_M, SIGNAL_VAR, NOISE_VAR, PRIOR_MEAN = math.exp(1.3) * CELL_M, math.exp(0.6), math.exp(0.7), 0.1
ALTITUDE_M = 11.5
SHOT_VAR = 1.0 - math.exp(-0.05 * ALTITUDE_M)  # var(h) = A (1 - exp(-B h)), A = 1, B = 0.05
THRESHOLD = 0.5


def phi(z):
    return 0.5 * (1.0 + math.erf(z / math.sqrt(2.0)))


def misclassification_reduction(mean, var, shot_var, rng, draws=2_000_000):
    """P(wrong side) now minus its expectation after one shot with noise shot_var."""
    truth = mean + math.sqrt(var) * rng.standard_normal(draws)
    seen = truth + math.sqrt(shot_var) * rng.standard_normal(draws)
    after_mean = mean + var / (var + shot_var) * (seen - mean)
    before = phi(-abs(THRESHOLD - mean) / math.sqrt(var))
    return before - np.mean((truth > THRESHOLD) != (after_mean > THRESHOLD))


def main():
    n = int(round(SIDE_M / CELL_M))
    centres = (np.arange(n) + 0.5) * CELL_M - SIDE_M / 2
    x, y = np.meshgrid(centres, centres)
    xy = np.stack([x.ravel(), y.ravel()], axis=1)
    r = math.sqrt(3.0) * np.linalg.norm(xy[:, None, :] - xy[None, :, :], axis=2) / LENGTH_M
    k = SIGNAL_VAR * (1.0 + r) * np.exp(-r)
    cov = k - k @ np.linalg.solve(k + NOISE_VAR * np.eye(n * n), k)
    mean = np.full(n * n, PRIOR_MEAN)

    def footprint(cx, cy):  # 45 x 60 degree camera, straight down
        half_x, half_y = math.tan(math.radians(22.5)) * ALTITUDE_M, math.tan(math.radians(30)) * ALTITUDE_M
        return np.where((abs(xy[:, 0] - cx) <= half_x) & (abs(xy[:, 1] - cy) <= half_y))[0]

    def fuse(mean, cov, cells, labels):
        s = cov[np.ix_(cells, cells)] + SHOT_VAR * np.eye(len(cells))
        gain = np.linalg.solve(s, cov[cells, :]).T
        return mean + gain @ (labels - mean[cells]), cov - gain @ cov[cells, :]

    # E5's p4: 0.75 x 2 m at (0, 9); the cells it overlaps.
    person = np.where((abs(xy[:, 0]) < 0.375 + CELL_M / 2) & (abs(xy[:, 1] - 9.0) < 1.0 + CELL_M / 2))[0]
    shot = footprint(0.0, 9.0)
    detected = np.isin(shot, person).astype(float)
    m1, c1 = fuse(mean, cov, shot, detected)
    m2, c2 = fuse(m1, c1, shot, np.zeros(len(shot)))
    m0, c0 = fuse(mean, cov, shot, np.zeros(len(shot)))
    cell = person[np.argmax(m2[person])]
    far = int(np.argmin(np.linalg.norm(xy - np.array([-12.0, -12.0]), axis=1)))
    rng = np.random.default_rng(1)
    print(f"footprint at {ALTITUDE_M} m: {len(shot)} cells; the person: {len(person)} cells; "
          f"shot noise variance {SHOT_VAR:.2f}")
    print(f"{'cell':34s} {'mean':>6s} {'variance':>9s} {'reduction':>10s}")
    for name, m, v in [("detected once, missed once (tie)", m2[cell], c2[cell, cell]),
                       ("detected once", m1[cell], c1[cell, cell]),
                       ("never seen", mean[far], cov[far, far]),
                       ("seen once, empty", m0[cell], c0[cell, cell])]:
        print(f"{name:34s} {m:6.3f} {v:9.4f} {misclassification_reduction(m, v, SHOT_VAR, rng):10.4f}")


if __name__ == "__main__":
    main()
