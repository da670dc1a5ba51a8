"""Peer timing: Magpylib's vectorized cylinder field on the same random points as
`porelab bench field` (R = 1 m, L = 2 m, box |x|,|y| <= 3, |z| <= 5), one call per batch.

Usage: taskset -c 0 python benches/peer_magpylib.py [N]   (default N = 1e6 points of the same
distribution; pin to one core for a per-core rate: unpinned, the call uses about two cores)
Prints points per second for longitudinal, transverse and oblique magnetization.
Needs `pip install magpylib numpy`; porelab itself never calls Python.
"""
import sys, time
import numpy as np
import magpylib as magpy

n = int(float(sys.argv[1])) if len(sys.argv) > 1 else 1_000_000
rng = np.random.default_rng(20261124)
pts = np.column_stack([rng.uniform(-3, 3, n), rng.uniform(-3, 3, n), rng.uniform(-5, 5, n)])
R, L, M0 = 1.0, 2.0, 1e6
cases = {
    "longitudinal": (0.0, 0.0, M0),
    "transverse": (M0, 0.0, 0.0),
    "oblique": tuple(np.array([1.0, 1.0, 1.0]) * M0 / np.sqrt(3.0)),
}
for name, m in cases.items():
    cyl = magpy.magnet.Cylinder(dimension=(2 * R, 2 * L), magnetization=m)
    cyl.getH(pts[:1000])  # warm-up
    best, best_cpu = 1e30, 1e30
    for _ in range(3):
        t0, c0 = time.perf_counter(), time.process_time()
        H = cyl.getH(pts)
        best = min(best, time.perf_counter() - t0)
        best_cpu = min(best_cpu, time.process_time() - c0)
    # (CPU time as well: on a shared machine the wall clock also counts other processes' turns)
    print(f"magpylib {magpy.__version__} {name:<13} {len(pts) / best:.4e} points/s (one call, best of 3)"
          f"  [cpu time: {len(pts) / best_cpu:.4e} points/s]")
