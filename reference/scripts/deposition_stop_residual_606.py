"""The residual gap the seed's displacement (window) stop rule leaves in case 606, without
porelab (numpy only).

One sphere (d = 1) settles at T = 0 in a periodic square column of side L: on the substrate
(layer 1, start 0.5 d above it, gap e = z - r), or on a stack at rest in its exact hollows
(layers 2 and up: the sphere below at the origin, the one two below at (L/2, L/2, -dz), both
with their periodic images; start 2 d above the sphere below; gap e = z - dz,
dz = sqrt(d^2 - L^2 / 2)). Moves by the seed's rule (Vidal, Zou & Uesaka 2004, eq. A13, A16:
zeta and six xi uniform, translation component sign(xi_i) sqrt(|xi_i| / sum |xi| zeta K_max);
K_max = 1e-14 m^2 with d = 1 um is K = 0.01 d^2); a trial is accepted iff it goes down and
keeps the sphere at least d from every other sphere (and r above the substrate). The stop rule
is porelab's reading of the seed's (engine.rs): the reference D1 is the first trial that moves;
the run stops when the mean displacement per trial over the last W trials (at least W trials
from the reference) falls below f D1. One trial per sweep: in the case the spheres below also
take trials, but at rest they add (almost) nothing to the window, and dividing both the window
mean and D1 by the sphere count leaves the rule unchanged.

Why the gap is left, and its scale: near the hollow (or the substrate) a sphere e above its
rest height accepts only the moves that land in the free region below it, whose size is of
order e, so the accepted fraction p(e) falls as e^2 / K (times a logarithm on the substrate)
and the accepted displacement per trial as e^3 / K. The window rule stops as soon as one
window of W trials holds accepted displacement below W f D1 (at f = 1e-4, W = 2000: about
10 nm in all, a few accepted moves of a few nm); a window with no accepted move at all
(probability exp(-W p(e))) always stops it. So the rule leaves a gap of the order of the e at
which W p(e) is of order 1, a few nm for W = 2000: the residual, a distribution, is what the
walkers below measure. Walkers that stop more than 0.05 d above their hollow are on a ridge
top (the seed's direction bias, deposition_ridge_606.py) and are counted apart.

The tolerance of case 606 per geometry is the largest gap left by N walkers that reach the
hollow basin (a fresh draw from the same rule exceeds the largest of N with probability
1 / (N + 1)).

  python3 deposition_stop_residual_606.py L_over_d|substrate walkers f W seed

Measured (2026-12, 1000 walkers, f = 1e-6, W = 2000, seed 606), gaps in nm with d = 1 um:
  substrate:  none on a ridge; median 0.199, 90 % 0.559, 99 % 0.979, largest 1.314
  L = 1.2 d:  270 on a ridge top; basin median 3.29, 90 % 5.53, 99 % 7.80, largest 11.34
  L = 1.05 d: 296 on a ridge top; basin median 2.58, 90 % 4.58, 99 % 7.31, largest 15.61
  L = 1.22 d: 266 on a ridge top; basin median 3.37, 90 % 5.87, 99 % 8.26, largest 11.50
and at f = 1e-4 (50 walkers, L = 1.2 d, seed 1): basin median 4.4, largest 12.2.
"""
import sys

import numpy as np

K = 0.01


def draw(rng, n):
    zeta = rng.random(n)
    xi = rng.random((n, 6)) * 2 - 1
    s = np.abs(xi).sum(1)
    return np.sign(xi[:, :3]) * np.sqrt(np.abs(xi[:, :3]) / s[:, None] * (zeta * K)[:, None])


def centres(L):
    if L is None:
        return np.zeros((0, 3))
    dz = np.sqrt(1 - L * L / 2)
    grid = [(sx * L, sy * L) for sx in range(-2, 3) for sy in range(-2, 3)]
    below = [(x, y, 0.0) for x, y in grid]
    two_below = [(x + L / 2, y + L / 2, -dz) for x, y in grid]
    return np.array(below + two_below)


def walk(L, walkers, f, W, seed):
    rng = np.random.default_rng(seed)
    c = centres(L)
    side = L if L is not None else 10.0
    if L is None:
        start, rest = 1.0, 0.5
    else:
        start, rest = 2.0, np.sqrt(1 - L * L / 2)
    pos = np.column_stack([rng.random(walkers) * side, rng.random(walkers) * side,
                           np.full(walkers, start)])
    ring = np.zeros((W, walkers))
    d1 = np.zeros(walkers)
    since = np.zeros(walkers, dtype=np.int64)
    done = np.zeros(walkers, bool)
    gap_at_stop = np.full(walkers, np.nan)
    trials_at_stop = np.zeros(walkers, dtype=np.int64)
    k = 0
    while not done.all():
        live = ~done
        t = draw(rng, walkers)
        trial = pos + t
        ok = (t[:, 2] < 0) & (trial[:, 2] >= 0.5) & live
        if len(c):
            d2 = ((trial[:, None, :2] - c[None, :, :2] + side / 2) % side - side / 2) ** 2
            d2 = d2.sum(2) + (trial[:, None, 2] - c[None, :, 2]) ** 2
            ok &= d2.min(1) >= 1.0
        step = np.where(ok, np.linalg.norm(t, axis=1), 0.0)
        pos[ok] = trial[ok]
        pos[:, :2] %= side
        new_ref = (d1 == 0) & (step > 0)
        d1[new_ref] = step[new_ref]
        ring[k % W] = step
        since[d1 > 0] += 1
        stop = live & (since >= max(W, 2)) & (ring.sum(0) / W < f * d1)
        gap_at_stop[stop] = pos[stop, 2] - rest
        trials_at_stop[stop] = k + 1
        done |= stop
        k += 1
    return gap_at_stop, trials_at_stop


def main():
    which, walkers, f, W, seed = sys.argv[1:6]
    L = None if which == "substrate" else float(which)
    gap, trials = walk(L, int(walkers), float(f), int(W), int(seed))
    ridge = gap > 0.05
    basin = gap[~ridge]
    q = np.quantile(basin, [0.5, 0.9, 0.99])
    print(f"{which}: {len(gap)} walkers, f = {f}, W = {W}, seed {seed}: on a ridge top "
          f"(> 0.05 d) {ridge.sum()}; basin gaps (nm, d = 1 um): median {q[0] * 1e3:.3f}, "
          f"90 % {q[1] * 1e3:.3f}, 99 % {q[2] * 1e3:.3f}, largest {basin.max() * 1e3:.3f}; "
          f"trials to stop median {int(np.median(trials))}, largest {trials.max()}")


if __name__ == "__main__":
    main()
