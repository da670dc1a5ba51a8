#!/usr/bin/env python3
"""Peer for `porelab bench lbm`: lbmpy's generated C kernel (fused stream-collide, pull,
structure of arrays, double precision, periodic n^3 box) for the same lattice and collision,
timed the same way (MLUPS = cells x steps / s). Threads via OMP_NUM_THREADS.
Prints one line `MLUPS <value>`."""
import argparse, os, sys, time

ap = argparse.ArgumentParser()
ap.add_argument("--stencil", default="D3Q19")
ap.add_argument("--method", default="srt", choices=["srt", "trt"])
ap.add_argument("--n", type=int, default=64)
ap.add_argument("--seconds", type=float, default=2.0)
a = ap.parse_args()

import numpy as np
import pystencils as ps
from lbmpy import LBMConfig, LBMOptimisation, LBStencil, Method, Stencil, create_lb_update_rule
from lbmpy.macroscopic_value_kernels import pdf_initialization_assignments

threads = int(os.environ.get("OMP_NUM_THREADS", "1"))
stencil = LBStencil(Stencil.D3Q15 if a.stencil.upper() == "D3Q15" else Stencil.D3Q19)
method = Method.SRT if a.method == "srt" else Method.TRT
n = a.n
# same relaxation as porelab's bench (tau = 1; TRT with Lambda = 3/16) and a Guo body force
omega = 1.0
if method == Method.TRT:
    rr = [omega, 1.0 / (0.5 + (3.0 / 16.0) / (1.0 / omega - 0.5))]
else:
    rr = [omega]
from lbmpy import ForceModel
dh = ps.create_data_handling((n, n, n), periodicity=True, default_target=ps.Target.CPU)
src = dh.add_array("src", values_per_cell=stencil.Q, layout="fzyx")
dst = dh.add_array_like("dst", "src")
cfg = LBMConfig(stencil=stencil, method=method, relaxation_rates=rr, compressible=True,
                force_model=ForceModel.GUO, force=(1e-6, 0, 0))
opt = LBMOptimisation(symbolic_field=src, symbolic_temporary_field=dst)
rule = create_lb_update_rule(lbm_config=cfg, lbm_optimisation=opt)
try:
    kcfg = ps.CreateKernelConfig(target=ps.Target.CPU)
    kcfg.cpu.openmp.enable = threads > 1
    kcfg.cpu.openmp.num_threads = threads
except Exception:
    kcfg = ps.CreateKernelConfig(target=ps.Target.CPU, cpu_openmp=threads if threads > 1 else False)
kernel = ps.create_kernel(rule, config=kcfg).compile()
dh.fill("src", 1.0 / stencil.Q)
dh.fill("dst", 1.0 / stencil.Q)
sync = dh.synchronization_function(["src"])

def step():
    sync()
    dh.run_kernel(kernel)
    dh.swap("src", "dst")

step()
steps, t0 = 0, time.perf_counter()
while steps < 3 or time.perf_counter() - t0 < a.seconds:
    step()
    steps += 1
dt = time.perf_counter() - t0
print(f"MLUPS {n**3 * steps / dt / 1e6:.4f}")
