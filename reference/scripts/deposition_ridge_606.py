"""Case 606's ridge lock, reproduced without porelab (numpy only).

One sphere (d = 1) settles at T = 0 on a fixed sphere and its periodic images (square column of
side L): a trial translation is accepted iff it goes down and keeps the sphere at least d from
every image. Directions either by the seed's rule (Vidal, Zou & Uesaka 2004, eq. A13, A16:
zeta and six xi uniform, translation component sign(xi_i) sqrt(|xi_i| / sum |xi| zeta K_max),
the three rotation shares drawn but unused for a sphere) or isotropic with the same lengths.
K_max = 1e-14 m^2 with d = 1 um is K = 0.01 d^2.

  python3 deposition_ridge_606.py walk 1.2 30000 400 a16    # walkers from random x, y, 2 d up
  python3 deposition_ridge_606.py walk 1.2 30000 400 iso
  python3 deposition_ridge_606.py rate 1.2                  # accepted downhill trials on the ridge

Measured (2026-12, seeds as below): L = 1.2 d, 400 walkers, gap above the hollow > 0.05 d after
1e3 / 3e3 / 1e4 / 3e4 trials: eq. A16 180 / 128 / 89 / 68, isotropic 28 / 2 / 0 / -; the
walkers left by eq. A16 sit at the top of a ridge (x = L/2 or y = L/2 within 0.02 d, gap
0.271 d = sqrt(d^2 - L^2/4) - sqrt(d^2 - L^2/2)). On the ridge at 0.005 / 0.02 / 0.05 / 0.1 /
0.2 d from its top, accepted downhill trials per trial (2e6 each): eq. A16 0 / 0 / 1.5e-6 /
1.15e-5 / 1.53e-4, isotropic 2.2e-4 / 3.1e-4 / 9.2e-4 / 2.5e-3 / 8.1e-3.
"""
import sys

import numpy as np

K = 0.01


def draw(rng, n, mode):
    zeta = rng.random(n)
    xi = rng.random((n, 6)) * 2 - 1
    s = np.abs(xi).sum(1)
    t = np.sign(xi[:, :3]) * np.sqrt(np.abs(xi[:, :3]) / s[:, None] * (zeta * K)[:, None])
    if mode == "a16":
        return t
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1)[:, None]
    return v * np.linalg.norm(t, axis=1)[:, None]


def images(L):
    return np.array([(sx * L, sy * L, 0.0) for sx in range(-2, 3) for sy in range(-2, 3)])


def accepted(p, t, img):
    trial = p + t
    d2 = ((trial[:, None, :] - img[None, :, :]) ** 2).sum(2).min(1)
    return (t[:, 2] < 0) & (d2 >= 1.0)


def walk(L, steps, walkers, mode):
    rng = np.random.default_rng(1)
    img = images(L)
    pos = np.column_stack([rng.random(walkers) * L, rng.random(walkers) * L, np.full(walkers, 2.0)])
    hollow = np.sqrt(1 - L * L / 2)
    for k in range(steps):
        t = draw(rng, walkers, mode)
        ok = accepted(pos, t, img)
        pos[ok] += t[ok]
        pos[:, :2] %= L
        if k + 1 in (1000, 3000, 10000, 30000, 100000):
            gap = pos[:, 2] - hollow
            print(f"L = {L} d, {mode}, {k + 1} trials: gap above the hollow > 0.05 d: "
                  f"{(gap > 0.05).sum()} of {walkers} (largest {gap.max():.4f} d)", flush=True)
    gap = pos[:, 2] - hollow
    for w in np.argsort(-gap)[:5]:
        print(f"  gap {gap[w]:.4f} d at x = {pos[w, 0]:.4f}, y = {pos[w, 1]:.4f} (mod L)")


def rate(L):
    rng = np.random.default_rng(5)
    img = images(L)
    for y in (0.005, 0.02, 0.05, 0.1, 0.2):
        p = np.array([L / 2, y, np.sqrt(1 - (L / 2) ** 2 - y * y) + 1e-9])
        t = draw(rng, 2_000_000, "a16")
        a16 = accepted(p, t, img).mean()
        t = draw(rng, 2_000_000, "iso")
        iso = accepted(p, t, img).mean()
        print(f"{y} d from the ridge top: accepted downhill per trial: eq. A16 {a16:.2e}, "
              f"isotropic {iso:.2e}")


if __name__ == "__main__":
    if sys.argv[1] == "walk":
        walk(float(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5])
    else:
        rate(float(sys.argv[2]))
