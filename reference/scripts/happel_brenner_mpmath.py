#!/usr/bin/env python3
"""Expected values of validation case 201 (Happel-Brenner resistance of ellipsoids).

Independent of porelab and of Carlson's integrals. mpmath at 50 digits (every value re-checked
at 70 digits; the script stops if the two differ by more than 1e-30 relative). Inputs are
doubles passed to mpmath exactly (mpf(float)); outputs are written with 17 significant digits.

Rows (quantity Ca, Cb, Cc = resistance along the a, b, c semi-axis, f = 3 / sum(1/C_i), or
Tij = entries of the world-frame tensor R diag(C) R^T):

* sphere: 6 pi mu a (Stokes).
* prolate (a = tau b > b = c, symmetry axis a) and oblate (a = b > c = b / tau, symmetry axis c),
  tau = 1.01 ... 100: Perrin's closed forms (F. Perrin, J. Phys. Radium 5, 497 (1934);
  Happel & Brenner, Low Reynolds number hydrodynamics, 1965, section 5-11), written here in the
  form obtained by doing the integrals chi, psi of seed 000 eq. A6-A7 in elementary terms
  (symmetry semi-axis s, equatorial semi-axis q, C_s = 16 pi mu / (chi + s^2 psi_s),
  C_q = 16 pi mu / (chi + q^2 psi_q)):
    prolate, e^2 = s^2 - q^2, L = artanh(e/s)/e:
      C_s = 8 pi mu e^2 / ((2 s^2 - q^2) L - s),   C_q = 16 pi mu e^2 / ((2 s^2 - 3 q^2) L + s);
    oblate, e^2 = q^2 - s^2, M = atan(e/s)/e:
      C_s = 8 pi mu e^2 / ((q^2 - 2 s^2) M + s),   C_q = 16 pi mu e^2 / ((3 q^2 - 2 s^2) M - s).
  (In tau = s/q for the prolate: C_s = 8 pi mu q (tau^2 - 1) / ((2 tau^2 - 1) ln(tau +
  sqrt(tau^2 - 1)) / sqrt(tau^2 - 1) - tau), Happel & Brenner's form.) The differences cancel
  ~ log10(1/(tau - 1)) digits near the sphere, harmless at 50 digits.
* disk: thin oblates c/a = 1e-1 ... 1e-8 (Perrin, exact), and c/a = 1e-14, 1e-15 against the
  disk limits 16 mu a (broadside, along c) and 32 mu a / 3 (edgewise) themselves (the exact
  values differ from the limits by (8/(3 pi)) c/a resp. c^2/(2 a^2) relative, < 1e-14).
* triaxial: direct tanh-sinh quadrature (mpmath.quad) of the definitions eq. A6-A8,
  chi = int_0^inf dl / Delta, psi_a = int_0^inf dl / ((a^2 + l) Delta): on [0, max a_i^2]
  in l, split at the squared semi-axes, and on the tail in u = l^(-1/2) (smooth integrand
  2 / sqrt(prod(1 + a_i^2 u^2)), times u^2 / (1 + a^2 u^2) for psi);
  C_a = 16 pi mu / (chi + a^2 psi_a) (eq. A4-A5).
* rotated: tensor entries R diag(C) R^T for a unit quaternion (x, y, z, w) (R from the
  quaternion by the textbook formula), triaxial C from the quadrature above.

Column scale_N_s_per_m: |value| for C and f; for tensor entries the largest C (the norm of
the tensor).

Usage: python3 reference/scripts/happel_brenner_mpmath.py [OUT.csv]
default OUT: validation/201-happel-brenner/expected.csv (relative to the repo root).
"""
import os
import sys

import mpmath as mp

DPS = 50
CHECK_DPS = 70


def f17(x):
    return mp.nstr(mp.mpf(x), 17, strip_zeros=False, min_fixed=1, max_fixed=0)


def spheroid(s, q, mu):
    """(C along the symmetry axis, C along an equatorial axis)."""
    s, q, mu = mp.mpf(s), mp.mpf(q), mp.mpf(mu)
    if s > q:
        e = mp.sqrt(s * s - q * q)
        L = mp.atanh(e / s) / e
        cs = 8 * mp.pi * mu * e * e / ((2 * s * s - q * q) * L - s)
        cq = 16 * mp.pi * mu * e * e / ((2 * s * s - 3 * q * q) * L + s)
    elif s < q:
        e = mp.sqrt(q * q - s * s)
        M = mp.atan(e / s) / e
        cs = 8 * mp.pi * mu * e * e / ((q * q - 2 * s * s) * M + s)
        cq = 16 * mp.pi * mu * e * e / ((3 * q * q - 2 * s * s) * M - s)
    else:
        cs = cq = 6 * mp.pi * mu * s
    return cs, cq


def triaxial(a, b, c, mu):
    ax = [mp.mpf(a), mp.mpf(b), mp.mpf(c)]
    sq = [x * x for x in ax]
    big = max(sq)
    pts = sorted(set([mp.mpf(0)] + sq))
    # [0, max a^2] in lambda (split at the squared semi-axes); the tail [max a^2, inf) in
    # u = lambda^(-1/2), where dlambda / Delta = 2 du / sqrt(prod(1 + a_i^2 u^2)) is smooth.
    u_top = 1 / mp.sqrt(big)

    def delta(l):
        return mp.sqrt((sq[0] + l) * (sq[1] + l) * (sq[2] + l))

    def tail_w(u):
        return 2 / mp.sqrt((1 + sq[0] * u * u) * (1 + sq[1] * u * u) * (1 + sq[2] * u * u))

    chi = mp.quad(lambda l: 1 / delta(l), pts) + mp.quad(tail_w, [0, u_top])
    out = []
    for i in range(3):
        psi = mp.quad(lambda l: 1 / ((sq[i] + l) * delta(l)), pts) + mp.quad(
            lambda u: tail_w(u) * u * u / (1 + sq[i] * u * u), [0, u_top])
        out.append(16 * mp.pi * mp.mpf(mu) / (chi + sq[i] * psi))
    return out


def rotation(qx, qy, qz, qw):
    x, y, z, w = (mp.mpf(v) for v in (qx, qy, qz, qw))
    n = mp.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]


def rows():
    """(kind, a, b, c, mu, quantity, value, scale, qx, qy, qz, qw) with mpf values."""
    out = []

    def add_c(kind, a, b, c, mu, cs):
        for name, v in zip(("Ca", "Cb", "Cc"), cs):
            out.append((kind, a, b, c, mu, name, v, abs(v), "", "", "", ""))
        f = 3 / sum(1 / v for v in cs)
        out.append((kind, a, b, c, mu, "f", f, abs(f), "", "", "", ""))

    for a, mu in [(1e-9, 8.9e-4), (1e-6, 1e-3), (1e-3, 1.0), (1.0, 1.0), (1e3, 1e3), (0.37, 2.5)]:
        v = 6 * mp.pi * mp.mpf(mu) * mp.mpf(a)
        add_c("sphere", a, a, a, mu, (v, v, v))
    taus = [1.01, 1.1, 1.5, 2.0, 3.0, 5.0, 10.0, 20.0, 50.0, 100.0]
    for tau in taus:
        for q, mu in [(1.0, 1.0), (1e-6, 1e-3)]:
            a = tau * q
            cs, cq = spheroid(a, q, mu)
            add_c("prolate", a, q, q, mu, (cs, cq, cq))
            c = q / tau
            cs, cq = spheroid(c, q, mu)
            add_c("oblate", q, q, c, mu, (cq, cq, cs))
    for k in range(1, 9):
        c = 10.0 ** (-k)
        cs, cq = spheroid(c, 1.0, 1.0)
        add_c("thin-oblate", 1.0, 1.0, c, 1.0, (cq, cq, cs))
    for c in [1e-14, 1e-15]:
        for a, mu in [(1.0, 1.0), (2e-6, 1e-3)]:
            edge = mp.mpf(32) / 3 * mp.mpf(mu) * mp.mpf(a)
            broad = 16 * mp.mpf(mu) * mp.mpf(a)
            for name, v in (("Ca", edge), ("Cb", edge), ("Cc", broad)):
                out.append(("disk-limit", a, a, c * a, mu, name, v, abs(v), "", "", "", ""))
    tri = [
        (3.0, 2.0, 1.0, 1.0),
        (1.0, 0.5, 0.2, 1.0),
        (1.2, 1.0, 0.8, 1e-3),
        (1.0, 1.001, 0.999, 1.0),
        (10.0, 1.0, 0.1, 1.0),
        (100.0, 10.0, 1.0, 1.0),
        (1.0, 0.01, 0.1, 1.0),
        (5e-6, 4e-6, 3e-6, 8.9e-4),
        (0.02, 1.0, 0.3, 2.0),
    ]
    tri_c = {}
    for a, b, c, mu in tri:
        cs = triaxial(a, b, c, mu)
        tri_c[(a, b, c, mu)] = cs
        add_c("triaxial", a, b, c, mu, cs)
    for (a, b, c, mu), q in [
        ((3.0, 2.0, 1.0, 1.0), (0.1, -0.3, 0.5, 0.8)),
        ((1.0, 0.01, 0.1, 1.0), (0.6, 0.2, -0.1, 0.7)),
    ]:
        cs = tri_c[(a, b, c, mu)]
        r = rotation(*q)
        cmax = max(cs)
        for i in range(3):
            for j in range(3):
                t = sum(r[i][k] * cs[k] * r[j][k] for k in range(3))
                out.append(("rotated", a, b, c, mu, "T%d%d" % (i, j), t, cmax) + tuple(q))
    return out


def main():
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        root, "validation", "201-happel-brenner", "expected.csv")
    mp.mp.dps = DPS
    # Perrin's closed forms against the quadrature of the definitions (both spheroid kinds).
    for s_, q_ in [(3.0, 1.0), (0.25, 1.0), (1.01, 1.0)]:
        cs, cq = spheroid(s_, q_, 1.0)
        t = triaxial(s_, q_, q_, 1.0)
        for x, y in ((cs, t[0]), (cq, t[1]), (cq, t[2])):
            if abs(x - y) > mp.mpf(10) ** -35 * abs(y):
                raise SystemExit("Perrin vs quadrature: %s vs %s" % (x, y))
    r1 = rows()
    mp.mp.dps = CHECK_DPS
    r2 = rows()
    for x, y in zip(r1, r2):
        if abs(x[6] - y[6]) > mp.mpf(10) ** -30 * abs(y[6]) + mp.mpf(10) ** -30 * abs(y[7]):
            raise SystemExit("precision check failed: %r vs %r" % (x, y))
    mp.mp.dps = DPS
    with open(out, "w") as fh:
        fh.write("# generated by reference/scripts/happel_brenner_mpmath.py (mpmath %d digits, "
                 "checked at %d); see case.toml\n" % (DPS, CHECK_DPS))
        fh.write("kind,a_m,b_m,c_m,viscosity_Pa_s,quantity,qx,qy,qz,qw,"
                 "expected_N_s_per_m,scale_N_s_per_m\n")
        for kind, a, b, c, mu, name, v, s, qx, qy, qz, qw in r1:
            fh.write("%s,%r,%r,%r,%r,%s,%s,%s,%s,%s,%s,%s\n" % (
                kind, float(a), float(b), float(c), float(mu), name,
                qx, qy, qz, qw, f17(v), f17(s)))
    print("wrote %d rows to %s" % (len(r1), out))


if __name__ == "__main__":
    main()
