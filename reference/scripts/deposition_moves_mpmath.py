"""Moments of the seed 000 move generator (eq. A13, A16), independent of porelab.

dz = sign(xi_z) sqrt(|xi_z| / sum_i |xi_i|) sqrt(zeta K_max), zeta ~ U(0, 1), xi_i ~ U(-1, 1),
i over six numbers. With u = |xi_z| ~ U(0, 1) and s the sum of the other five |xi| (Irwin-Hall
density of order 5),
  E|dz| / sqrt(K_max) = E[sqrt(zeta)] E[sqrt(u / (u + s))] = (2/3) E[sqrt(u / (u + s))],
  E[dz^2] / K_max = E[zeta] E[u / (u + s)] = (1/2)(1/6) = 1/12 (symmetry of the six shares).
An isolated sphere at T = 0 accepts exactly the moves with dz < 0 (half of them), and descends
E[-dz; dz < 0] = E|dz| / 2 per trial; E[dz^2; dz < 0] = K_max / 24.
Run: python3 reference/scripts/deposition_moves_mpmath.py
"""
import mpmath as mp

mp.mp.dps = 30


def irwin_hall(n, s):
    k = mp.mpf(0)
    for j in range(0, int(mp.floor(s)) + 1):
        k += (-1) ** j * mp.binomial(n, j) * (s - j) ** (n - 1)
    return k / mp.factorial(n - 1)


def inner(u):
    return mp.quad(lambda s: mp.sqrt(u / (u + s)) * irwin_hall(5, s), [0, 1, 2, 3, 4, 5])


e_sqrt_share = mp.quad(inner, [0, 1])
e_abs_dz = mp.mpf(2) / 3 * e_sqrt_share
print("E|dz|/sqrt(K_max) =", mp.nstr(e_abs_dz, 15))
print("E[descent per trial]/sqrt(K_max) =", mp.nstr(e_abs_dz / 2, 15))
print("E[dz^2]/K_max =", mp.nstr(mp.mpf(1) / 12, 15))
