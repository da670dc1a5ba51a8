#!/usr/bin/env python3
"""Oracle for the exact sphere-box volume of the coupled porosity (src/coupled/porosity.rs).

Independent of porelab and of its closed forms: the volume of {|p - c| < r} inside the box
[x0, x1] x [y0, y1] x [z0, z1] is the plain double integral, over the box's (x, y) rectangle,
of the length of the sphere's vertical chord clipped to [z0, z1],

    V = int_x0^x1 int_y0^y1 max(0, min(z1, h) - max(z0, -h)) dy dx,  h = sqrt(r^2 - x^2 - y^2)

(coordinates relative to the centre), integrated numerically by mpmath's tanh-sinh rule at 30
digits. The inner integral is split where the clipped chord changes form (h = |z0|, |z1|, 0)
and the outer one where those breakpoints cross the rectangle's edges, so every piece is smooth
inside with at most sqrt-type ends (which tanh-sinh integrates to full precision). No
antiderivative, no spherical cap or octant formula is used. The error column is mpmath's own
estimate summed over the pieces (outer estimate plus the largest inner one times the width).

Cases: fixed hand-picked geometries (a sphere centred on a corner, an edge, a face; cut by one,
two or three faces; a corner of the box grazing the sphere at 1 - 1e-6 r; a sphere larger than
the box; the box inside the sphere but for one corner) and 24 random ones from Python's
random.Random(20261202) (centre uniform in [-0.6, 1.6]^3 around the unit box, r uniform in
[0.15, 0.9]; 10 of them miss the box, volume 0). Written with 17 significant digits.

Usage: python3 reference/scripts/sphere_box_mpmath.py [OUT.csv]
default OUT: reference/sphere_box_volume.csv. About a minute on one core.
"""
import os
import random
import sys

import mpmath as mp

mp.mp.dps = 30


def chord(r, x, y, z0, z1):
    h2 = r * r - x * x - y * y
    if h2 <= 0:
        return mp.mpf(0)
    h = mp.sqrt(h2)
    return max(mp.mpf(0), min(z1, h) - max(z0, -h))


def piecewise(f, a, b, r2s):
    """int_a^b f, split at +-sqrt(s2) for the s2 > 0 in r2s inside (a, b); (value, err)."""
    pts = {a, b}
    for s2 in r2s:
        if s2 > 0:
            s = mp.sqrt(s2)
            pts.update(v for v in (-s, s) if a < v < b)
    pts = sorted(pts)
    val, err = mp.mpf(0), mp.mpf(0)
    for p, q in zip(pts, pts[1:]):
        v, e = mp.quad(f, [p, q], error=True)
        val += v
        err += e
    return val, err


def volume(c, r, lo, hi):
    c = [mp.mpf(v) for v in c]
    r = mp.mpf(r)
    x0, y0, z0 = (mp.mpf(lo[k]) - c[k] for k in range(3))
    x1, y1, z1 = (mp.mpf(hi[k]) - c[k] for k in range(3))
    x0, x1 = max(x0, -r), min(x1, r)
    y0, y1 = max(y0, -r), min(y1, r)
    if x0 >= x1 or y0 >= y1 or max(z0, -r) >= min(z1, r):
        return mp.mpf(0), mp.mpf(0)
    zs = (z0, z1, mp.mpf(0))
    worst_inner = [mp.mpf(0)]

    def f(x):
        # inner breakpoints: y where h = |z0|, |z1| or 0
        v, e = piecewise(
            lambda y: chord(r, x, y, z0, z1), y0, y1, [r * r - x * x - zb * zb for zb in zs]
        )
        worst_inner[0] = max(worst_inner[0], e)
        return v

    # outer breakpoints: x where an inner breakpoint y = +-sqrt(r^2 - x^2 - zb^2) meets an
    # edge y = yb (or y = 0, where the two branches meet)
    s2 = [r * r - yb * yb - zb * zb for yb in (y0, y1, mp.mpf(0)) for zb in zs]
    val, err = piecewise(f, x0, x1, s2)
    return val, err + worst_inner[0] * (x1 - x0)


def cases():
    unit = ([0.0, 0.0, 0.0], [1.0, 1.0, 1.0])
    fixed = [
        ([1.0, 1.0, 1.0], 0.4),  # centred on a corner: 1/8
        ([1.0, 1.0, 0.5], 0.4),  # on an edge: 1/4
        ([0.5, 1.0, 0.5], 0.4),  # on a face: 1/2
        ([0.5, 0.5, 0.5], 0.4),  # inside: whole sphere
        ([0.5, 0.5, 0.83], 0.4),  # one face cut
        ([0.5, 0.79, 0.83], 0.4),  # two faces, edge inside the sphere
        ([0.81, 0.79, 0.83], 0.4),  # three faces, corner inside the sphere
        ([1.2, 1.15, 1.1], 0.4),  # centre outside, corner region only
        ([1.1, 0.5, 0.5], 0.4),  # centre outside, beyond one face
        ([1.13, 1.21, 0.5], 0.4),  # centre outside, beyond an edge
        ([0.5, 0.5, 0.5], 0.7),  # sphere larger than half the box: both faces of each axis
        ([0.3, 0.6, 0.4], 0.9),
        ([0.5, 0.5, 0.5], 0.8),  # box inside the sphere but for its corners
        ([0.0, 0.0, 0.0], 1.6),  # box inside the sphere but for one corner
    ]
    # a corner grazing the sphere: distance from the centre to the corner (1,1,1) = r (1 - 1e-6)
    r = 0.4
    d = r * (1.0 - 1e-6) / 3.0**0.5
    fixed.append(([1.0 - d, 1.0 - d, 1.0 - d], r))
    # an edge grazing the sphere
    d = r * (1.0 - 1e-6) / 2.0**0.5
    fixed.append(([1.0 - d, 1.0 - d, 0.5], r))
    out = [(c, rr, *unit) for c, rr in fixed]
    rng = random.Random(20261202)
    for _ in range(24):
        c = [rng.uniform(-0.6, 1.6) for _ in range(3)]
        out.append((c, rng.uniform(0.15, 0.9), *unit))
    return out


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    path = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "sphere_box_volume.csv")
    rows = ["cx,cy,cz,r,x0,y0,z0,x1,y1,z1,volume,abs_err_est"]
    for c, r, lo, hi in cases():
        v, e = volume(c, r, lo, hi)
        vals = [*c, r, *lo, *hi]
        rows.append(
            ",".join(repr(float(x)) for x in vals)
            + f",{mp.nstr(v, 17, min_fixed=-1, max_fixed=-1)},{mp.nstr(e, 3)}"
        )
        print(rows[-1], flush=True)
    with open(path, "w") as f:
        f.write("\n".join(rows) + "\n")


if __name__ == "__main__":
    main()
