#!/usr/bin/env python3
"""Reference values of the complete elliptic integrals for validation case 001.

Independent of porelab: every value is computed with mpmath at 100 significant digits
(checked against a 130-digit recomputation) and written with 17 significant digits, which
round-trips to the nearest double. Inputs are chosen as doubles and passed to mpmath
*exactly* (mpf(float)), so the only difference between the table and the true function
value at the double input is the final rounding (<= 0.5 ulp).

Conventions (those of porelab::special::elliptic):
  K(m), E(m)        parameter m = k^2                          (DLMF 19.2.8)
  Pi(n, m)          characteristic n, parameter m              (DLMF 19.2.7, 19.2.8)
  cel(kc, p, a, b)  Bulirsch, int_0^{pi/2} (a cos^2 + b sin^2) /
                    ((cos^2 + p sin^2) sqrt(cos^2 + kc^2 sin^2))   (thesis eq. 5.36)
                    = a R_F(0, kc^2, 1) + (b - p a)/3 R_J(0, kc^2, 1, p)   (p > 0; from DLMF 19.25.2)
  R_F, R_D, R_J     Carlson symmetric integrals (DLMF 19.16)
cel is computed from the Carlson form above and, where the integrand is smooth enough,
also by mpmath tanh-sinh quadrature; the script stops if the two disagree.
Column scale_dimensionless is the scale of the relative tolerance (see scale_of).

Closed-form rows ("closed" in the source column) are evaluated from their closed form at
40 digits and checked against the general mpmath routine.

Usage: python3 reference/scripts/elliptic_mpmath.py [OUT.csv]
default OUT: validation/001-elliptic-integrals/expected.csv (relative to the repo root).
"""
import os
import sys

import mpmath as mp

DPS = 100  # working precision (> the 40 digits asked for: some cel rows cancel ~20 digits)
CHECK_DPS = 130  # every value is recomputed at this precision and must agree to 1e-35


def K(m):
    return mp.ellipk(m)


def E(m):
    return mp.ellipe(m)


def PI(n, m):
    return mp.ellippi(n, m)


def cel_carlson(kc, p, a, b):
    kc2 = kc * kc
    return a * mp.elliprf(0, kc2, 1) + (b - p * a) / 3 * mp.elliprj(0, kc2, 1, p)


def cel_quad(kc, p, a, b):
    f = lambda t: (a * mp.cos(t) ** 2 + b * mp.sin(t) ** 2) / (
        (mp.cos(t) ** 2 + p * mp.sin(t) ** 2) * mp.sqrt(mp.cos(t) ** 2 + kc**2 * mp.sin(t) ** 2)
    )
    return mp.quad(f, [0, mp.pi / 4, mp.pi / 2])


def scale_of(func, margs, v):
    """Scale of the relative tolerance. |value| for all functions but cel, whose value can
    cancel (b = -a sqrt(p) at kc = 1 gives exactly 0): there the scale is the integral of the
    absolute integrand, cel(kc, p, |a|, |b|) >= |cel|, i.e. the size of what a stable
    algorithm sums; it equals |cel| whenever a and b have the same sign."""
    if func == "cel":
        kc, p, a, b = margs
        return cel_carlson(kc, p, abs(a), abs(b))
    return abs(v)


FUNCS = {
    "K": lambda a: K(a[0]),
    "E": lambda a: E(a[0]),
    "Pi": lambda a: PI(a[0], a[1]),
    "cel": lambda a: cel_carlson(*a),
    "RF": lambda a: mp.elliprf(*a),
    "RD": lambda a: mp.elliprd(*a),
    "RJ": lambda a: mp.elliprj(*a),
}


def rows():
    out = []  # (func, args (floats), value (mpf), source, region)

    def add(func, args, source="mpmath", region="regular", value=None):
        args = [float(x) for x in args]
        margs = [mp.mpf(x) for x in args]
        v = FUNCS[func](margs) if value is None else value
        out.append((func, args, v, source, region))

    # --- K(m), E(m): m from 0 to 1 - 1e-15 (the field needs m = 1 - k^2 in [0, 1)).
    ms = [0.0, 1e-300, 1e-16, 1e-10, 1e-6, 1e-3, 0.01, 0.1, 0.25, 0.3, 0.5, 0.6, 0.75, 0.9,
          0.99, 0.999]
    near1 = [1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 1e-13, 1e-14, 1e-15]
    for m in ms:
        add("K", [m])
        add("E", [m])
    for d in near1:
        m = 1.0 - d
        add("K", [m], region="m->1")
        add("E", [m], region="m->1")
    for m in [-1.0, -10.0, -1e6]:  # negative parameter (imaginary modulus)
        add("K", [m])
        add("E", [m])
    add("E", [1.0], region="m->1")

    # --- Pi(n, m): n from -1e6 to 0.999, m over [0, 1 - 1e-15].
    ns = [-1e6, -1e3, -10.0, -1.0, -0.5, -1e-3, 0.0, 1e-3, 0.3, 0.5, 0.9, 0.99, 0.999]
    pm = [0.0, 1e-10, 0.1, 0.5, 0.9, 0.999, 1 - 1e-8, 1 - 1e-12, 1 - 1e-15]
    for n in ns:
        for m in pm:
            add("Pi", [n, m], region="m->1" if m > 0.9999 else "regular")
    # n close to m and n = m (Pi(m, m) = E(m)/(1-m) is a closed form, checked below)
    for n, m in [(0.5, 0.5 + 1e-9), (0.9, 0.9), (0.999, 0.998), (0.25, 0.75)]:
        add("Pi", [n, m])

    # --- cel(kc, p, a, b): kc from 1e-12 to 1, p from 1e-24 to 1, the (a, b) the field uses:
    # (1, 1) -> K-type, (1, -1) -> P1 of eq. 5.4, (1, -gamma) with p = gamma^2 -> P2, and a
    # general pair.
    kcs = [1e-12, 1e-8, 1e-4, 1e-2, 0.1, 0.5, 0.9, 1.0]
    # p = gamma^2 with gamma = (rho - R)/(rho + R): points 1e-10 R from the lateral surface
    # need p ~ 1e-21, hence the extra values below 1e-12.
    ps = [1e-24, 1e-20, 1e-16, 1e-12, 1e-8, 1e-4, 1e-2, 0.25, 1.0]
    for kc in kcs:
        for p in ps:
            reg = "corner" if (kc <= 1e-8 or p <= 1e-8) else "regular"
            add("cel", [kc, p, 1.0, 1.0], region=reg)
            g = float(mp.sqrt(mp.mpf(p)))
            # P2-type: p = gamma^2 with b = -gamma (gamma < 0 inside -> b > 0) and b = +gamma
            add("cel", [kc, p, 1.0, g], region=reg)
            add("cel", [kc, p, 1.0, -g], region=reg)
            add("cel", [kc, p, 0.3, -2.5], region=reg)
        add("cel", [kc, 1.0, 1.0, -1.0], region="corner" if kc <= 1e-8 else "regular")

    # --- Carlson: the arguments the complete integrals use, plus general ones.
    for kc in kcs:
        y = kc * kc
        reg = "corner" if kc <= 1e-8 else "regular"
        add("RF", [0.0, y, 1.0], region=reg)
        add("RD", [0.0, y, 1.0], region=reg)
        for p in ps:
            add("RJ", [0.0, y, 1.0, p], region="corner" if (kc <= 1e-8 or p <= 1e-8) else "regular")
    for x, y, z in [(1.0, 2.0, 3.0), (0.5, 1.0, 1e6), (1e-10, 1.0, 1.0), (2.0, 3.0, 4.0),
                    (1e-300, 1.0, 2.0), (1e3, 1e-3, 1.0)]:
        add("RF", [x, y, z])
        add("RD", [x, y, z])
    for x, y, z, p in [(1.0, 2.0, 3.0, 4.0), (0.5, 1.0, 1.5, 1e-8), (2.0, 3.0, 4.0, 5.0),
                       (0.0, 1.0, 2.0, 1e6), (1.0, 1.0, 1.0, 0.5)]:
        add("RJ", [x, y, z, p])

    # --- Exact closed forms (value from the closed form; checked against mpmath below).
    pi = mp.pi
    g14 = mp.gamma(mp.mpf(1) / 4)
    add("K", [0.0], "closed:pi/2", value=pi / 2)
    add("E", [0.0], "closed:pi/2", value=pi / 2)
    add("Pi", [0.0, 0.0], "closed:pi/2", value=pi / 2)
    add("E", [1.0], "closed:1", value=mp.mpf(1))
    add("K", [0.5], "closed:Gamma(1/4)^2/(4 sqrt(pi))", value=g14**2 / (4 * mp.sqrt(pi)))
    add("E", [0.5], "closed:(Gamma(1/4)^4+8pi^2)/(8 sqrt(pi) Gamma(1/4)^2)",
        value=(g14**4 + 8 * pi**2) / (8 * mp.sqrt(pi) * g14**2))
    for n in [-1e6, -3.0, 0.5, 0.75, 0.999]:
        add("Pi", [n, 0.0], "closed:pi/(2 sqrt(1-n))", value=pi / (2 * mp.sqrt(1 - mp.mpf(n))))
    for m in [0.5, 0.9]:
        mm = mp.mpf(m)
        add("Pi", [m, m], "closed:E(m)/(1-m)", value=E(mm) / (1 - mm))
        add("Pi", [0.0, m], "closed:K(m)", value=K(mm))
    add("cel", [1.0, 1.0, 1.0, 1.0], "closed:pi/2", value=pi / 2)
    for p, a, b in [(0.25, 1.0, 1.0), (4.0, 1.0, -1.0), (1e-12, 1.0, 1.0), (0.25, 0.3, -2.5)]:
        sp = mp.sqrt(mp.mpf(p))
        add("cel", [1.0, p, a, b], "closed:pi/2 (a sqrt(p)+b)/(sqrt(p)(1+sqrt(p)))",
            value=pi / 2 * (a * sp + b) / (sp * (1 + sp)))
    for x in [0.25, 1.0, 7.0]:
        xm = mp.mpf(x)
        add("RF", [x, x, x], "closed:x^-1/2", value=1 / mp.sqrt(xm))
        add("RD", [x, x, x], "closed:x^-3/2", value=xm ** mp.mpf(-1.5))
        add("RJ", [x, x, x, x], "closed:x^-3/2", value=xm ** mp.mpf(-1.5))
    add("RF", [0.0, 1.0, 1.0], "closed:pi/2", value=pi / 2)
    add("RF", [0.0, 4.0, 4.0], "closed:pi/4", value=pi / 4)
    return out


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.dirname(os.path.dirname(here))
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        root, "validation", "001-elliptic-integrals", "expected.csv")
    mp.mp.dps = DPS
    table = rows()
    # Check every value at CHECK_DPS digits (and each closed form against the general routine).
    mp.mp.dps = CHECK_DPS
    for func, args, v, source, _ in table:
        margs = [mp.mpf(x) for x in args]
        w = FUNCS[func](margs)
        if abs(v - w) > mp.mpf(10) ** -35 * scale_of(func, margs, w):
            raise SystemExit(f"{func}{args}: {source} value {v} vs CHECK_DPS-digit {w}")
    # cel: Carlson form against direct quadrature at 40 digits where the integrand is smooth.
    mp.mp.dps = 40
    for func, args, v, source, _ in table:
        margs = [mp.mpf(x) for x in args]
        if func == "cel" and margs[0] >= 1e-2 and margs[1] >= 1e-2:
            q = cel_quad(*margs)
            if abs(q - v) > mp.mpf(10) ** -30 * scale_of(func, margs, v):
                raise SystemExit(f"cel{args}: Carlson {v} vs quadrature {q}")
    mp.mp.dps = DPS
    with open(out + ".tmp", "w") as f:
        f.write("function,arg1,arg2,arg3,arg4,value_dimensionless,scale_dimensionless,"
                "source,region\n")
        for func, args, v, source, region in table:
            a = [repr(x) for x in args] + [""] * (4 - len(args))
            sc = scale_of(func, [mp.mpf(x) for x in args], v)
            f.write(f"{func},{','.join(a)},{mp.nstr(v, 17, min_fixed=1, max_fixed=0)},"
                    f"{mp.nstr(sc, 17, min_fixed=1, max_fixed=0)},\"{source}\",{region}\n")
    os.replace(out + ".tmp", out)
    print(f"wrote {len(table)} rows to {out}")


if __name__ == "__main__":
    main()
