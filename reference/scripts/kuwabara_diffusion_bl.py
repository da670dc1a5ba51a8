#!/usr/bin/env python3
"""Single-fibre Brownian (diffusion) capture efficiency in Kuwabara's cell flow, thin
concentration boundary layer (Peclet number Pe = 2 a U / D >> 1). No porelab code.

Flow: Kuwabara (1959) stream function around a cylinder of radius a in a cell of radius
b = a / sqrt(alpha), superficial velocity U along +z, theta measured from +z:
    psi = f(r) sin(theta),
    f(r) = U/(2 Ku) [ r (2 ln(r/a) - 1 + alpha) + (1 - alpha/2) a^2 / r - (alpha/2) r^3 / a^2 ],
    Ku = -ln(alpha)/2 - 3/4 + alpha - alpha^2/4.
The script checks its boundary conditions numerically (no slip at r = a, psi = U b sin(theta)
and zero vorticity at r = b) and takes the wall shear tau(theta) = |d u_theta / d r| at r = a
by numerical differentiation (mpmath), not from the closed form.

Capture: a thin concentration layer over a wall with linear shear u = tau(x) y (x along the
wall from the front stagnation point) has the local flux (generalized Leveque solution)
    j(x) = c0 D sqrt(tau(x)) / (9^(1/3) Gamma(4/3) (D int_0^x sqrt(tau) dx')^(1/3)),
so one half of the fibre (theta from pi to 0) collects
    J_half = (3/2) c0 D^(2/3) (int_0^{pi a} sqrt(tau) dx)^(2/3) / (9^(1/3) Gamma(4/3)),
and eta = 2 J_half / (2 a U c0). The closed form this gives,
    eta = A ((1 - alpha)/Ku)^(1/3) Pe^(-2/3),  A = 3 I^(2/3) / (9^(1/3) Gamma(4/3)) = 2.8907...,
    I = int_0^pi sqrt(sin t) dt,
is compared with the numerical quadrature (self-check). The 2.9 commonly quoted for
Stechkina & Fuchs (1966) is this A rounded.

Output: reference/kuwabara_diffusion.csv, columns solid_fraction, ku, pe, eta_bl, a_prefactor.
"""
import csv
import os

import mpmath as mp

mp.mp.dps = 30


def kuwabara(alpha):
    return -mp.log(alpha) / 2 - mp.mpf(3) / 4 + alpha - alpha**2 / 4


def f_stream(r, a, alpha, u):
    ku = kuwabara(alpha)
    return u / (2 * ku) * (r * (2 * mp.log(r / a) - 1 + alpha)
                           + (1 - alpha / 2) * a**2 / r - alpha / 2 * r**3 / a**2)


def eta_boundary_layer(alpha, pe, a=mp.mpf(1), u=mp.mpf(1)):
    d = 2 * a * u / pe
    b = a / mp.sqrt(alpha)
    f = lambda r: f_stream(r, a, alpha, u)
    # boundary conditions of the cell model
    assert abs(f(a)) < 1e-25 and abs(mp.diff(f, a)) < 1e-20
    assert abs(f(b) - u * b) < 1e-20
    vort = mp.diff(f, b, 2) + mp.diff(f, b) / b - f(b) / b**2
    assert abs(vort) < 1e-18, vort
    # u_theta = -f'(r) sin(theta); wall shear |f''(a)| sin(theta)
    shear0 = abs(mp.diff(f, a, 2))
    sqrt_tau = mp.quad(lambda t: mp.sqrt(shear0 * mp.sin(t)), [0, mp.pi]) * a
    j_half = mp.mpf(3) / 2 * d ** (mp.mpf(2) / 3) * sqrt_tau ** (mp.mpf(2) / 3) / (
        mp.cbrt(9) * mp.gamma(mp.mpf(4) / 3))
    return 2 * j_half / (2 * a * u)


def main():
    i_sin = mp.quad(lambda t: mp.sqrt(mp.sin(t)), [0, mp.pi])
    a_closed = 3 * i_sin ** (mp.mpf(2) / 3) / (mp.cbrt(9) * mp.gamma(mp.mpf(4) / 3))
    rows = []
    for alpha in [mp.mpf("0.1")]:
        ku = kuwabara(alpha)
        for pe in [mp.mpf(1000), mp.mpf(3000), mp.mpf(10000)]:
            eta = eta_boundary_layer(alpha, pe)
            a_num = eta * pe ** (mp.mpf(2) / 3) / ((1 - alpha) / ku) ** (mp.mpf(1) / 3)
            assert abs(a_num / a_closed - 1) < 1e-15, (a_num, a_closed)
            rows.append([float(alpha), float(ku), float(pe), float(eta), float(a_num)])
    print(f"A = {mp.nstr(a_closed, 10)} (closed form), I = {mp.nstr(i_sin, 10)}")
    out = os.path.join(os.path.dirname(__file__), "..", "kuwabara_diffusion.csv")
    with open(out, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["solid_fraction", "ku", "pe", "eta_bl", "a_prefactor"])
        for r in rows:
            w.writerow([repr(x) for x in r])
            print(r)


if __name__ == "__main__":
    main()
