#!/usr/bin/env python3
"""Pore size distribution (local thickness) of a fixed bed of spheres by PoreSpy.

Reads reference/pore_size_bed.xyz (extended XYZ: Lattice, pbc="T T F", radius column),
voxelizes it between the lowest and highest sphere centres by the rule of porelab's
`voxelize_bed` (lateral edge lx / round(lx / (<D>/VOXELS_PER_D)), the same edge in y and z,
round((z_hi - z_lo) / edge) layers from z_lo; a voxel is solid when its centre lies strictly
inside a sphere, minimum image in x and y), pads the image periodically in x and y, runs
PoreSpy's distance-transform local thickness (method 'legacy', every distinct distance value
as a size, `smooth=False`: voxels within <= r of a seed with dt >= r), crops the pad and
writes the fraction of the pore voxels carrying each local-thickness radius to
reference/pore_size_porespy.csv.

Usage: python3 reference/scripts/pore_size_porespy.py   (needs numpy, porespy, edt)
"""

import pathlib
import sys

import numpy as np
import porespy as ps
from edt import edt

VOXELS_PER_D = 8.0
HERE = pathlib.Path(__file__).resolve().parent.parent


def read_xyz(path):
    lines = path.read_text().splitlines()
    n = int(lines[0])
    header = lines[1]
    lat = header.split('Lattice="')[1].split('"')[0].split()
    lx, ly = float(lat[0]), float(lat[4])
    rows = [l.split() for l in lines[2:2 + n]]
    pos = np.array([[float(r[1]), float(r[2]), float(r[3])] for r in rows])
    rad = np.array([float(r[11]) for r in rows])
    return lx, ly, pos, rad


def voxelize(lx, ly, pos, rad):
    d_mean = 2.0 * rad.mean()
    voxel = d_mean / VOXELS_PER_D
    nx = max(1, round(lx / voxel))
    h = lx / nx
    ny = max(1, round(ly / h))
    hy = ly / ny
    z_lo, z_hi = pos[:, 2].min(), pos[:, 2].max()
    nz = max(1, round((z_hi - z_lo) / h))
    xc = (np.arange(nx) + 0.5) * h
    yc = (np.arange(ny) + 0.5) * hy
    zc = z_lo + (np.arange(nz) + 0.5) * h
    solid = np.zeros((nx, ny, nz), dtype=bool)
    for (cx, cy, cz), r in zip(pos, rad):
        dx = xc - cx
        dx -= lx * np.round(dx / lx)
        dy = yc - cy
        dy -= ly * np.round(dy / ly)
        dz = zc - cz
        d2 = dx[:, None, None] ** 2 + dy[None, :, None] ** 2 + dz[None, None, :] ** 2
        solid |= d2 < r * r
    return ~solid, (h, hy, h), (nx, ny, nz), (z_lo, z_hi)


def main():
    lx, ly, pos, rad = read_xyz(HERE / "pore_size_bed.xyz")
    pore, spacing, shape, zr = voxelize(lx, ly, pos, rad)
    if abs(spacing[1] - spacing[0]) > 1e-12 * spacing[0]:
        sys.exit("anisotropic voxels: PoreSpy's spheres need cubic voxels")
    dt0 = edt(pore)
    pad = 3 * int(np.ceil(dt0.max())) + 3
    big = np.pad(pore, ((pad, pad), (pad, pad), (0, 0)), mode="wrap")
    dt = edt(big)
    sizes = np.unique(dt[big])
    lt = ps.filters.local_thickness(big, dt=dt, method="legacy", sizes=sizes, smooth=False)
    lt = lt[pad:-pad, pad:-pad, :]
    radii = lt[pore]
    if np.any(radii <= 0):
        sys.exit("a pore voxel was left without a size")
    values, counts = np.unique(radii, return_counts=True)
    total = radii.size
    out = HERE / "pore_size_porespy.csv"
    with out.open("w") as f:
        f.write(f"# PoreSpy {ps.__version__} local_thickness(method='legacy', every distinct dt "
                f"value, smooth=False) of reference/pore_size_bed.xyz\n")
        f.write(f"# grid {shape[0]} x {shape[1]} x {shape[2]} voxels of edge {spacing[0]!r} m "
                f"(<D>/{VOXELS_PER_D}), z from {float(zr[0])!r} to {float(zr[1])!r} m; "
                f"pore voxels {total}, porosity {total / pore.size!r}; periodic pad {pad}\n")
        f.write("radius_voxels,pore_volume_fraction,pore_voxels\n")
        for v, c in zip(values, counts):
            f.write(f"{float(v)!r},{float(c / total)!r},{c}\n")
    print(f"wrote {out}: {len(values)} sizes, {total} pore voxels")


if __name__ == "__main__":
    main()
