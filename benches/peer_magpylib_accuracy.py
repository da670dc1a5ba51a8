"""Peer accuracy: Magpylib's cylinder field against porelab's independent oracle table
(reference/cylinder_field.csv), worst |H - H_ref|/|H_ref| per region, to compare with case 104.

Usage: python benches/peer_magpylib_accuracy.py [reference/cylinder_field.csv]
Needs `pip install magpylib numpy`; porelab itself never calls Python.
"""
import sys
import numpy as np
import magpylib as magpy

path = sys.argv[1] if len(sys.argv) > 1 else "reference/cylinder_field.csv"
rows = np.genfromtxt(path, delimiter=",", names=True, dtype=None, encoding="utf-8")
worst = {}
for r in rows:
    cyl = magpy.magnet.Cylinder(
        dimension=(2 * r["radius_m"], 2 * r["half_length_m"]),
        magnetization=(r["mx_A_per_m"], r["my_A_per_m"], r["mz_A_per_m"]),
    )
    h = cyl.getH((r["x_m"], r["y_m"], r["z_m"]))
    ref = np.array([r["Hx_A_per_m"], r["Hy_A_per_m"], r["Hz_A_per_m"]])
    err = np.linalg.norm(h - ref) / np.linalg.norm(ref)
    if not np.isfinite(err):
        err = np.inf
    w = worst.setdefault(r["region"], [0.0, 0, 0])
    w[0] = max(w[0], err)
    w[1] += 1
    w[2] += err > 1e-12
print(f"magpylib {magpy.__version__}: worst relative error of H per region against {path}")
for region, (e, n, bad) in sorted(worst.items()):
    print(f"  {region:<10} {n:>4} points  worst {e:.3e}  rows above 1e-12: {bad}")
