#!/usr/bin/env python3
"""Expected tables of the analytic limit cases of the cylinder field (validation 101-103).

Independent of porelab: closed forms and limits of thesis 003 section 5.5, evaluated with
mpmath at 40+ digits at the *exact* double inputs (coordinates are rounded to doubles first,
then passed to mpmath), written with 17 significant digits.

Conventions (porelab::magnetics::Cylinder): cylinder of radius R, half-length L, centred at
the origin, axis z, uniform magnetization M (A/m); H = Hess(psi) M with the Newtonian
potential psi(r) = (1/4 pi) int_cyl dV'/|r - r'| (so trace Hess psi = -1 inside, 0 outside).

101 infinite cylinder (eq. 5.24) at the midplane z = 0 with L/R = 1e6..1e8:
    transverse M_t: H = -M_t/2 inside; H = R^2/(2 rho^4) [2 (M_t.rho) rho - rho^2 M_t] outside
    (eq. 5.24 written in Cartesian form), longitudinal M_z: H = 0 (both sides).
    Leading finite-length correction (derived, see derive_101_correction below), uniform near
    the midplane: dH = + M_t R^2/(4 L^2) - M_z z_hat R^2/(2 L^2), with a remainder
    O(M (R/L)^2 (rho/L)^2 + M (R/L)^4) < 1e-19 M here. The correction is included in the
    expected value; the script checks it against a direct 1-D quadrature of the exact
    surface-charge integral (eq. 5.9 differentiated) at a few points.
102 field on and near the axis (eq. 5.26-5.27; solenoid formula):
    S(z) = f(z+L) - f(z-L), f(xi) = xi/sqrt(xi^2 + R^2)
    on axis: H_x = -M_x S/4, H_y = -M_y S/4, H_z = M_z (S/2 - [inside])
    at (x, y) with rho = |(x, y)| = 1e-12 R, to first order in rho (the O(rho^2) remainder is
    < 1e-20 |H| here): T_xz = T_zx = psi_xxz x, T_yz = T_zy = psi_xxz y with
    psi_xxz = -S'(z)/4, S'(z) = f'(z+L) - f'(z-L), f'(xi) = R^2/(xi^2 + R^2)^(3/2).
103 far field: the exterior multipole series of psi, exact for r > sqrt(R^2 + L^2):
    psi = (1/4 pi) sum_{l even} q_l P_l(cos theta) / r^(l+1),
    q_l = int_cyl r'^l P_l(cos theta') dV'
        = sum_k (-1)^k l! / (4^k k!^2 (l-2k)!) * 2 pi R^(2k+2)/(2k+2) * 2 L^(l-2k+1)/(l-2k+1),
    q_0 = V = 2 pi R^2 L (dipole m = M V), q_2 = V (L^2/3 - R^2/4). Summed until the terms
    are below 1e-30 of the total; H = Hess(psi) M by mpmath numerical differentiation at 60
    digits. The table also gives the l = 0 (dipole, eq. 5.31/5.35) and l = 2 parts.

Usage: python3 reference/scripts/cylinder_limits_mpmath.py [101|102|103 ...]
writes validation/10N-*/expected.csv.
"""
import math
import os
import sys

import mpmath as mp

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
M0 = 8.0e5  # A/m, the thesis' permanent magnet (section 5.6)


def s17(x):
    return mp.nstr(mp.mpf(x), 17, min_fixed=1, max_fixed=0)


def write(folder, header, rows):
    path = os.path.join(ROOT, "validation", folder, "expected.csv")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path + ".tmp", "w") as f:
        f.write(",".join(header) + "\n")
        for r in rows:
            f.write(",".join(s17(v) if not isinstance(v, str) else v for v in r) + "\n")
    os.replace(path + ".tmp", path)
    print(f"wrote {len(rows)} rows to {path}")


def mvec(v):
    return [mp.mpf(float(c)) for c in v]


# ---------------------------------------------------------------------------------------
# exact field by 1-D quadrature of the lateral surface-charge integral (transverse M only):
# sigma = M_t . n(phi') on rho' = R; the z' integral done in closed form.
def h_transverse_quad(R, L, Mx, My, x, y, z):
    R, L, Mx, My, x, y, z = map(mp.mpf, (R, L, Mx, My, x, y, z))

    def comps(ph):
        c, s = mp.cos(ph), mp.sin(ph)
        dx, dy = x - R * c, y - R * s
        s2 = dx * dx + dy * dy
        xp, xm = z + L, z - L
        a = xp / (s2 * mp.sqrt(s2 + xp**2)) - xm / (s2 * mp.sqrt(s2 + xm**2))
        b = -1 / mp.sqrt(s2 + xp**2) + 1 / mp.sqrt(s2 + xm**2)
        sig = (Mx * c + My * s) * R / (4 * mp.pi)
        return sig * dx * a, sig * dy * a, sig * b

    phi0 = mp.atan2(y, x)
    pts = sorted({mp.mpf(0), 2 * mp.pi} | {(phi0 + k * mp.pi / 2) % (2 * mp.pi) for k in range(4)})
    return [mp.quad(lambda t, i=i: comps(t)[i], pts) for i in range(3)]


# ---------------------------------------------------------------------------------------
def case_101():
    mp.mp.dps = 40
    R = 0.3
    rows = []
    rhos_in = [0.0, 0.3, 0.9, 0.999]
    rhos_out = [1.001, 1.5, 3.0, 10.0, 100.0]
    phis = [0.0, 0.7, 2.5, -1.9]
    mags = {
        "transverse_x": (M0, 0.0, 0.0),
        "transverse_oblique": (M0 * math.cos(1.1), M0 * math.sin(1.1), 0.0),
        "longitudinal": (0.0, 0.0, M0),
    }
    for ratio in [1e6, 1e7, 1e8]:
        L = R * ratio
        for mname, mv in mags.items():
            Mx, My, Mz = mvec(mv)
            for inside, rset in ((True, rhos_in), (False, rhos_out)):
                for rr in rset:
                    for phi in (phis if rr > 0 else [0.0]):
                        x = rr * R * math.cos(phi)
                        y = rr * R * math.sin(phi)
                        X, Y = mp.mpf(x), mp.mpf(y)
                        Rm, Lm = mp.mpf(R), mp.mpf(L)
                        r2 = X * X + Y * Y
                        assert (r2 < Rm * Rm) == inside
                        if inside:
                            hx, hy = -Mx / 2, -My / 2
                        else:
                            md = Mx * X + My * Y
                            hx = Rm**2 / (2 * r2**2) * (2 * md * X - r2 * Mx)
                            hy = Rm**2 / (2 * r2**2) * (2 * md * Y - r2 * My)
                        hz = mp.mpf(0)
                        # leading finite-length correction (uniform near the midplane)
                        hx += Mx * Rm**2 / (4 * Lm**2)
                        hy += My * Rm**2 / (4 * Lm**2)
                        hz += -Mz * Rm**2 / (2 * Lm**2)
                        hn = mp.sqrt(hx**2 + hy**2 + hz**2)
                        mn = mp.sqrt(Mx**2 + My**2 + Mz**2)
                        # scale: |M| inside (H is a difference of O(M) terms) and for the
                        # longitudinal exterior (H -> 0: the limit is 0, and the error unit of
                        # the O(M) surface field); |H| for the transverse exterior.
                        scale = mn if (inside or mname == "longitudinal") else hn
                        region = "inside" if inside else "outside"
                        rows.append([mname, region, R, L, x, y, 0.0, mv[0], mv[1], mv[2],
                                     hx, hy, hz, scale])
    # self-check of the derived correction against the exact surface-charge quadrature
    mp.mp.dps = 50
    for ratio in [1e6]:
        L = R * ratio
        for (rr, phi) in [(0.3, 0.7), (3.0, 2.5), (10.0, 0.0)]:
            x, y = rr * R * math.cos(phi), rr * R * math.sin(phi)
            q = h_transverse_quad(R, L, M0, 0.0, x, y, 0.0)
            row = next(r for r in rows if r[0] == "transverse_x" and r[3] == L
                       and r[4] == x and r[5] == y)
            for i in range(3):
                if abs(q[i] - row[10 + i]) > mp.mpf(10) ** -18 * M0:
                    raise SystemExit(f"101 correction check failed at {rr},{phi}: {q} vs {row[10:13]}")
            # and the correction itself is resolved (exact minus L=inf limit != 0)
    mp.mp.dps = 40
    header = ["magnetization", "region", "R_m", "L_m", "x_m", "y_m", "z_m", "Mx_A_per_m",
              "My_A_per_m", "Mz_A_per_m", "Hx_A_per_m", "Hy_A_per_m", "Hz_A_per_m",
              "scale_A_per_m"]
    write("101-infinite-cylinder", header, rows)


# ---------------------------------------------------------------------------------------
def case_102():
    mp.mp.dps = 40
    rows = []
    R = 0.3
    mags = {
        "transverse_x": (M0, 0.0, 0.0),
        "transverse_oblique": (M0 * math.cos(2.0), M0 * math.sin(2.0), 0.0),
        "longitudinal": (0.0, 0.0, M0),
        "mixed": (M0 / math.sqrt(2), 0.0, M0 / math.sqrt(2)),
    }
    zfr = [0.0, 0.5, -0.5, 0.9, 0.999, -0.999, 1.001, -1.001, 1.5, 3.0, -10.0, 1e3]
    for ratio in [0.01, 1.0, 20.0, 100.0]:
        L = R * ratio
        for mname, mv in mags.items():
            Mx, My, Mz = mvec(mv)
            for zf in zfr:
                z = zf * L
                for kind, rho_f, phi in [("axis", 0.0, 0.0), ("near_axis", 1e-12, 0.0),
                                         ("near_axis", 1e-12, 2.3)]:
                    x = rho_f * R * math.cos(phi)
                    y = rho_f * R * math.sin(phi)
                    Rm, Lm, X, Y, Z = map(mp.mpf, (R, L, x, y, z))
                    f = lambda xi: xi / mp.sqrt(xi**2 + Rm**2)
                    fp = lambda xi: Rm**2 / (xi**2 + Rm**2) ** mp.mpf(1.5)
                    S = f(Z + Lm) - f(Z - Lm)
                    Sp = fp(Z + Lm) - fp(Z - Lm)
                    inside = (X * X + Y * Y < Rm * Rm) and abs(Z) < Lm
                    txx = -S / 4
                    tzz = S / 2 - (1 if inside else 0)
                    txxz = -Sp / 4
                    hx = txx * Mx + txxz * X * Mz
                    hy = txx * My + txxz * Y * Mz
                    hz = tzz * Mz + txxz * (X * Mx + Y * My)
                    hn = mp.sqrt(hx**2 + hy**2 + hz**2)
                    rows.append([mname, kind, "inside" if inside else "outside", R, L, x, y, z,
                                 mv[0], mv[1], mv[2], hx, hy, hz, hn])
    header = ["magnetization", "kind", "region", "R_m", "L_m", "x_m", "y_m", "z_m",
              "Mx_A_per_m", "My_A_per_m", "Mz_A_per_m", "Hx_A_per_m", "Hy_A_per_m",
              "Hz_A_per_m", "scale_A_per_m"]
    write("102-on-axis", header, rows)


# ---------------------------------------------------------------------------------------
def q_l(l, R, L):
    R, L = mp.mpf(R), mp.mpf(L)
    tot = mp.mpf(0)
    for k in range(l // 2 + 1):
        c = mp.mpf((-1) ** k * math.factorial(l)) / (4**k * math.factorial(k) ** 2 * math.factorial(l - 2 * k))
        n = l - 2 * k
        tot += c * 2 * mp.pi * R ** (2 * k + 2) / (2 * k + 2) * 2 * L ** (n + 1) / (n + 1)
    return tot


def case_103():
    mp.mp.dps = 60
    rows = []
    R = 0.3
    mags = {
        "transverse_x": (M0, 0.0, 0.0),
        "longitudinal": (0.0, 0.0, M0),
        "oblique": (M0 * 0.48, -M0 * 0.6, M0 * 0.64),
    }
    # L/R = sqrt(3)/2 makes q_2 = 0 (the deviation from the dipole is then O((a/d)^4))
    ratios = [("0.1", 0.1), ("1", 1.0), ("10", 10.0), ("sqrt3/2", math.sqrt(3) / 2)]
    dists = [2.0, 4.0, 10.0, 30.0, 100.0, 300.0, 1e3, 1e4, 1e6]
    dirs = [(0.0, 0.0), (0.4, 0.0), (math.pi / 2, 1.0), (2.2, 1.0), (math.pi, 0.0)]
    for rname, ratio in ratios:
        L = R * ratio
        a = math.sqrt(R * R + L * L)
        qs = []
        lmax = 400
        for l in range(0, lmax + 1, 2):
            qs.append((l, q_l(l, R, L)))
        assert abs(qs[1][1] - qs[0][1] * (mp.mpf(L) ** 2 / 3 - mp.mpf(R) ** 2 / 4)) < mp.mpf(10) ** -50

        for dfac in dists:
            d = dfac * a
            for th, ph in dirs:
                x = d * math.sin(th) * math.cos(ph)
                y = d * math.sin(th) * math.sin(ph)
                z = d * math.cos(th)
                X, Y, Z = mp.mpf(x), mp.mpf(y), mp.mpf(z)
                r0 = mp.sqrt(X * X + Y * Y + Z * Z)
                # number of terms: (a/r)^l below 1e-32
                nterm = int(32 / math.log10(float(r0) / a)) + 4
                terms = [(l, q) for (l, q) in qs if l <= nterm]
                assert terms[-1][0] < lmax, "series too long"

                def psi_part(ls):
                    def f(xx, yy, zz):
                        r = mp.sqrt(xx * xx + yy * yy + zz * zz)
                        t = zz / r
                        return sum(q * mp.legendre(l, t) / r ** (l + 1) for (l, q) in ls) / (4 * mp.pi)
                    return f

                def hess(f):
                    H = [[None] * 3 for _ in range(3)]
                    for i in range(3):
                        for j in range(i, 3):
                            o = [0, 0, 0]
                            o[i] += 1
                            o[j] += 1
                            H[i][j] = H[j][i] = mp.diff(f, (X, Y, Z), tuple(o))
                    return H

                Hs = {k: hess(psi_part(v)) for k, v in
                      (("full", terms), ("l0", terms[:1]), ("l2", terms[1:2]))}
                for mname, mv in mags.items():
                    Mv = mvec(mv)
                    out = []
                    for k in ("full", "l0", "l2"):
                        T = Hs[k]
                        out.append([sum(T[i][j] * Mv[j] for j in range(3)) for i in range(3)])
                    hn = mp.sqrt(sum(c * c for c in out[0]))
                    rows.append([rname, mname, R, L, repr(dfac), x, y, z, mv[0], mv[1], mv[2]]
                                + out[0] + out[1] + out[2] + [hn])
    # the dipole part must be the point-dipole field (eq. 5.31, 5.35 for M along x)
    for r in rows:
        Rr, Ll = mp.mpf(r[2]), mp.mpf(r[3])
        X, Y, Z = map(mp.mpf, r[5:8])
        Mv = [mp.mpf(v) for v in r[8:11]]
        m = [2 * mp.pi * Rr**2 * Ll * c for c in Mv]
        rr = mp.sqrt(X * X + Y * Y + Z * Z)
        p = [X, Y, Z]
        md = sum(mi * pi for mi, pi in zip(m, p))
        hd = [(3 * md * p[i] / rr**2 - m[i]) / (4 * mp.pi * rr**3) for i in range(3)]
        for i in range(3):
            if abs(hd[i] - r[14 + i]) > mp.mpf(10) ** -30 * r[-1]:
                raise SystemExit(f"dipole check failed: {hd} vs {r[14:17]}")
    header = ["aspect_L_over_R", "magnetization", "R_m", "L_m", "d_over_a", "x_m", "y_m", "z_m",
              "Mx_A_per_m", "My_A_per_m", "Mz_A_per_m",
              "Hx_A_per_m", "Hy_A_per_m", "Hz_A_per_m",
              "Hx_dipole_A_per_m", "Hy_dipole_A_per_m", "Hz_dipole_A_per_m",
              "Hx_l2_A_per_m", "Hy_l2_A_per_m", "Hz_l2_A_per_m", "scale_A_per_m"]
    rows = [[v if not isinstance(v, str) else v for v in r] for r in rows]
    write("103-far-field-dipole", header, rows)


if __name__ == "__main__":
    which = sys.argv[1:] or ["101", "102", "103"]
    for w in which:
        {"101": case_101, "102": case_102, "103": case_103}[w]()
