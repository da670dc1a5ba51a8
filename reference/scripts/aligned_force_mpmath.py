#!/usr/bin/env python3
"""Expected table of validation case 422: the force on a superparamagnetic particle aligned
with the local field, F = mu0 |m| (h . grad) H with h = (H0 + H) / |H0 + H| (thesis 003,
eq. 6.20 and section 6.4.1), outside a uniformly magnetized finite cylinder.

Independent of porelab: H and its gradient come from the exterior multipole series of the
Newtonian potential of the cylinder (the method of case 103, reference/scripts/
cylinder_limits_mpmath.py), exact for r > a = sqrt(R^2 + L^2) (R radius, L half-length):

    psi = (1/4 pi) sum_{l even} q_l P_l(cos theta) / r^(l+1),
    q_l = sum_k (-1)^k l! / (4^k k!^2 (l-2k)!) * 2 pi R^(2k+2)/(2k+2) * 2 L^(l-2k+1)/(l-2k+1),

summed until (a/r)^l < 1e-34, in the cylinder frame (axis z'); H_i = psi_ij M_j and
dH_i/dx_k = psi_ijk M_j by mpmath numerical differentiation at 60 digits, then rotated to the
world frame (the series is symmetric about the axis, so any frame completing the axis serves).
Inputs are rounded to doubles first; outputs written with 17 significant digits. A self-check
repeats one point at 90 digits and demands agreement to 1e-30.

Usage: python3 reference/scripts/aligned_force_mpmath.py
writes validation/422-aligned-dipole-force/expected.csv.
"""
import math
import os

import mpmath as mp

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
MU0 = mp.mpf("1.25663706212e-6")  # CODATA 2018 (the value porelab uses)
MU_P = 5.151e-16  # A m^2, Table 6.1 moment of the 125 nm particles


def s17(x):
    return mp.nstr(mp.mpf(x), 17, min_fixed=1, max_fixed=0)


def q_l(l, R, L):
    tot = mp.mpf(0)
    for k in range(l // 2 + 1):
        c = mp.mpf((-1) ** k * math.factorial(l)) / (
            4**k * math.factorial(k) ** 2 * math.factorial(l - 2 * k))
        n = l - 2 * k
        tot += c * 2 * mp.pi * R ** (2 * k + 2) / (2 * k + 2) * 2 * L ** (n + 1) / (n + 1)
    return tot


def frame(axis):
    """Orthonormal e1, e2, u (u = axis) as mpf triples."""
    u = [mp.mpf(c) for c in axis]
    n = mp.sqrt(sum(c * c for c in u))
    u = [c / n for c in u]
    t = [1, 0, 0] if abs(u[0]) < 0.9 else [0, 1, 0]
    d = sum(a * b for a, b in zip(t, u))
    e1 = [a - d * b for a, b in zip(t, u)]
    n1 = mp.sqrt(sum(c * c for c in e1))
    e1 = [c / n1 for c in e1]
    e2 = [u[1] * e1[2] - u[2] * e1[1], u[2] * e1[0] - u[0] * e1[2], u[0] * e1[1] - u[1] * e1[0]]
    return [e1, e2, u]


def field_and_gradient(R, L, centre, axis, M, p, dps=60):
    """World-frame H (A/m) and G[i][k] = dH_i/dx_k (A/m^2) at p."""
    with mp.workdps(dps):
        R, L = mp.mpf(R), mp.mpf(L)
        F = frame(axis)  # rows: body axes in world coordinates
        rel = [mp.mpf(p[i]) - mp.mpf(centre[i]) for i in range(3)]
        X = [sum(F[b][i] * rel[i] for i in range(3)) for b in range(3)]
        Mb = [sum(F[b][i] * mp.mpf(M[i]) for i in range(3)) for b in range(3)]
        a = mp.sqrt(R * R + L * L)
        r0 = mp.sqrt(sum(c * c for c in X))
        assert r0 > a, "point inside the circumscribed sphere: the series does not converge"
        lmax = int(math.ceil(34 / math.log10(float(r0 / a)))) + 2
        qs = [(l, q_l(l, R, L)) for l in range(0, lmax + 1, 2)]

        def psi(x, y, z):
            r = mp.sqrt(x * x + y * y + z * z)
            t = z / r
            return sum(q * mp.legendre(l, t) / r ** (l + 1) for (l, q) in qs) / (4 * mp.pi)

        def d(orders):
            return mp.diff(psi, tuple(X), tuple(orders))

        hess = [[None] * 3 for _ in range(3)]
        for i in range(3):
            for j in range(i, 3):
                o = [0, 0, 0]
                o[i] += 1
                o[j] += 1
                hess[i][j] = hess[j][i] = d(o)
        third = {}
        for i in range(3):
            for j in range(i, 3):
                for k in range(j, 3):
                    o = [0, 0, 0]
                    o[i] += 1
                    o[j] += 1
                    o[k] += 1
                    third[(i, j, k)] = d(o)

        def t3(i, j, k):
            return third[tuple(sorted((i, j, k)))]

        Hb = [sum(hess[i][j] * Mb[j] for j in range(3)) for i in range(3)]
        Gb = [[sum(t3(i, j, k) * Mb[j] for j in range(3)) for k in range(3)] for i in range(3)]
        # world = F^T body
        H = [sum(F[b][i] * Hb[b] for b in range(3)) for i in range(3)]
        G = [[sum(F[b][i] * Gb[b][c] * F[c][k] for b in range(3) for c in range(3))
              for k in range(3)] for i in range(3)]
        return H, G


def main():
    mp.mp.dps = 60
    ms = 985e3
    s2 = math.sqrt(0.5)
    magnets = [
        # name, R, L (half-length), centre, axis, M
        ("LD5/3_alpha90_M_along_field", 300e-6, 500e-6, (0.0, 0.0, 0.0), (0.0, 0.0, 1.0),
         (ms, 0.0, 0.0)),
        ("LD5/3_alpha45_M_along_field", 300e-6, 500e-6, (0.0, 0.0, 0.0), (s2, 0.0, s2),
         (ms, 0.0, 0.0)),
        ("LD20/3_alpha0_longitudinal", 300e-6, 2e-3, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0),
         (ms, 0.0, 0.0)),
        ("LD1_posed_oblique_M", 300e-6, 300e-6, (1e-3, -2e-3, 5e-4), (0.36, 0.48, 0.8),
         (ms * 0.6, -ms * 0.64, ms * 0.48)),
    ]
    dists = [1.5, 3.0, 10.0, 100.0, 1000.0]
    dirs = [(0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.6, 0.0, 0.8), (1.0, 1.0, 1.0),
            (-0.3, 0.9, -0.2)]
    rows = []
    checked = False
    for name, R, L, c, ax, M in magnets:
        a = math.sqrt(R * R + L * L)
        for dfac in dists:
            for dv in dirs:
                n = math.sqrt(sum(x * x for x in dv))
                p = tuple(c[i] + dfac * a * dv[i] / n for i in range(3))
                H, G = field_and_gradient(R, L, c, ax, M, p)
                if not checked:
                    H2, G2 = field_and_gradient(R, L, c, ax, M, p, dps=90)
                    gn = mp.sqrt(sum(G[i][k] ** 2 for i in range(3) for k in range(3)))
                    err = max(abs(G[i][k] - G2[i][k]) for i in range(3) for k in range(3))
                    assert err < mp.mpf(10) ** -30 * gn, f"precision self-check failed: {err}"
                    checked = True
                hn = mp.sqrt(sum(x * x for x in H))
                gnorm = mp.sqrt(sum(G[i][k] ** 2 for i in range(3) for k in range(3)))
                for h0name, h0 in (("H0=1T_x", (float(1 / MU0), 0.0, 0.0)),
                                   ("H0=0", (0.0, 0.0, 0.0)),
                                   ("H0=|H|_y", (0.0, float(hn), 0.0))):
                    ht = [mp.mpf(h0[i]) + H[i] for i in range(3)]
                    tn = mp.sqrt(sum(x * x for x in ht))
                    f = [MU0 * mp.mpf(MU_P) * sum(G[i][k] * ht[k] for k in range(3)) / tn
                         for i in range(3)]
                    scale = MU0 * mp.mpf(MU_P) * gnorm
                    rows.append([name, R, L, *c, *ax, *M, repr(dfac), *p, *h0, MU_P, *f, scale])
    header = ["magnet", "radius_m", "half_length_m", "cx_m", "cy_m", "cz_m", "ax", "ay", "az",
              "mx_A_per_m", "my_A_per_m", "mz_A_per_m", "d_over_a", "x_m", "y_m", "z_m",
              "h0x_A_per_m", "h0y_A_per_m", "h0z_A_per_m", "moment_A_m2",
              "Fx_N", "Fy_N", "Fz_N", "scale_N"]
    path = os.path.join(ROOT, "validation", "422-aligned-dipole-force", "expected.csv")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path + ".tmp", "w") as fh:
        fh.write("# Generated by reference/scripts/aligned_force_mpmath.py (mpmath, 60 digits):\n")
        fh.write("# F = mu0 mu (h . grad) H, h = (H0 + H)/|H0 + H|, H and grad H from the exact\n")
        fh.write("# exterior multipole series of the cylinder (r > sqrt(R^2 + L^2)).\n")
        fh.write("# scale_N = mu0 mu |grad H|_F, the size of the force's error scale.\n")
        fh.write(",".join(header) + "\n")
        for r in rows:
            fh.write(",".join(v if isinstance(v, str) else s17(v) for v in r) + "\n")
    os.replace(path + ".tmp", path)
    print(f"wrote {len(rows)} rows to {path}")


if __name__ == "__main__":
    main()
