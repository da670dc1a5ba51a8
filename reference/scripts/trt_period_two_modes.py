"""Permeability of a voxelised sphere packing by an independent D3Q19 TRT code (NumPy, no
porelab code): k read at one step and averaged over two consecutive steps, at several tau.

Halfway bounce-back leaves modes of eigenvalue -1 at fluid nodes in one-cell gaps; read at one
step they add an offset that does not scale with 1/nu, so k appears to depend on tau at a fixed
magic parameter. Averaged over two steps it does not (src/lbm/driver.rs,
fields_over_two_steps).

Usage: python3 trt_period_two_modes.py FINAL_XYZ CELLS [STEPS]
FINAL_XYZ: porelab's extended XYZ of spheres (`porelab run --builtin packing-spheres`).
Measured (12 cells, 60,000 steps; k in lattice units): at the last step 0.012736 / 0.012368 /
0.011142 at tau 0.7 / 1 / 2 (at the step before: 0.013227 / 0.013595 / 0.014822); two-step mean
0.0129817851 at all three.
"""
import sys
import numpy as np

C = np.array([[0, 0, 0], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1],
              [1, 1, 0], [-1, -1, 0], [1, -1, 0], [-1, 1, 0], [1, 0, 1], [-1, 0, -1],
              [1, 0, -1], [-1, 0, 1], [0, 1, 1], [0, -1, -1], [0, 1, -1], [0, -1, 1]])
W = np.array([1 / 3] + [1 / 18] * 6 + [1 / 36] * 12)
OPP = np.array([0, 2, 1, 4, 3, 6, 5, 8, 7, 10, 9, 12, 11, 14, 13, 16, 15, 18, 17])
CS2 = 1 / 3


def solid_mask(path, n):
    """Cells whose centre lies inside a sphere (periodic images included)."""
    lines = open(path).read().splitlines()
    count = int(lines[0])
    header = lines[1]
    edge = float(header.split('Lattice="')[1].split()[0])
    props = header.split("Properties=")[1].split()[0].split(":")
    cols, at = {}, 0
    for name, kind, width in zip(props[0::3], props[1::3], props[2::3]):
        cols[name] = at
        at += int(width)
    rows = [l.split() for l in lines[2:2 + count]]
    pos = np.array([[float(v) for v in r[cols["pos"]:cols["pos"] + 3]] for r in rows])
    rad = np.array([float(r[cols["radius"]]) for r in rows])
    g = (np.arange(n) + 0.5) * edge / n
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    pts = np.stack([x.ravel(), y.ravel(), z.ravel()], 1)
    solid = np.zeros(len(pts), bool)
    for p, r in zip(pos, rad):
        d = pts - p
        d -= edge * np.round(d / edge)
        solid |= (d * d).sum(1) < r * r
    return solid.reshape(n, n, n)


def permeability(solid, tau, steps, magic=3 / 16, force=1e-6):
    """k along z read at the last step and averaged over the last two."""
    n = solid.shape[0]
    fluid = np.argwhere(~solid)
    index = -np.ones(solid.shape, int)
    index[tuple(fluid.T)] = np.arange(len(fluid))
    nf = len(fluid)
    pull = np.empty((nf, 19), int)
    for i in range(19):
        j = index[tuple(((fluid - C[i]) % n).T)]
        pull[:, i] = np.where(j >= 0, j * 19 + i, np.arange(nf) * 19 + OPP[i])
    tau_minus = 0.5 + magic / (tau - 0.5)
    g = np.array([0, 0, force])
    source = W * (C @ g) / CS2  # the antisymmetric Guo source at the bare-momentum equilibrium
    f = np.tile(W, (nf, 1))
    nu = CS2 * (tau - 0.5)
    ks = []
    for s in range(steps + 1):
        rho, j = f.sum(1), f @ C
        e = W * (rho[:, None] + (j @ C.T) / CS2)  # Stokes equilibrium
        fo, eo = f[:, OPP], e[:, OPP]
        post = f - 0.5 * ((f + fo) - (e + eo)) / tau - 0.5 * ((f - fo) - (e - eo)) / tau_minus
        f = (post + source).ravel()[pull]
        if s >= steps - 1:
            ks.append(nu * ((f @ C)[:, 2].sum() + nf * force / 2) / n**3 / force)
    return ks[-1], 0.5 * (ks[-1] + ks[-2])


if __name__ == "__main__":
    path, cells = sys.argv[1], int(sys.argv[2])
    steps = int(sys.argv[3]) if len(sys.argv) > 3 else 60000
    mask = solid_mask(path, cells)
    print(f"{cells} cells, fluid fraction {1 - mask.mean():.4f}")
    for tau in (0.7, 1.0, 2.0):
        one, two = permeability(mask, tau, steps)
        print(f"tau {tau}: k at one step {one:.10f}, two-step mean {two:.10f}")
