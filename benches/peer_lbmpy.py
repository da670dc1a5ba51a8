#!/usr/bin/env python3
"""Peer for `porelab bench lbm`: lbmpy's generated C kernel for the same lattice, collision and
body force as porelab's, timed the same way (MLUPS = updated cells x steps / s). Threads via
OMP_NUM_THREADS. Prints one line `MLUPS <value>`, then one `# ...` line saying what ran.

Two problems:
- plain (default): a periodic n^3 box, MLUPS over all cells;
- pores (`--mask FILE.npy`): lbmpy's dense kernel over the whole box with lbmpy's NoSlip
  boundary handling (halfway bounce-back, generated index-list kernel) on the solid cells of a
  uint8 mask of shape (nz, ny, nx) (x fastest, as porelab writes it, 1 = solid), periodic,
  MLUPS counting fluid cells only, as porelab's pore kernels do.

Same physics as porelab's bench: tau = 1 (omega = 1); TRT with Lambda = 3/16, i.e. the odd
rate 1 / (1/2 + (3/16) / (1/omega - 1/2)); Guo forcing, a = 1e-6 along x; compressible
equilibrium; double precision.

The choices a careful lbmpy user makes, each measured on this host (Intel Xeon, AVX-512,
2 cores, lbmpy 2.0, pystencils 2.0, g++ 12 at pystencils' default -Ofast -march=native;
D3Q19 TRT, figures in benches/RESULTS.md):
- Periodicity: `--periodic kernel` (default) runs lbmpy's own periodicity handling
  (`LBMPeriodicityHandling`, which copies only the populations that cross each face and edge)
  as generated pystencils copy kernels, one per face and edge, the way lbmpy builds them for
  GPUs (`periodic_pdf_gpu_copy_kernel`), compiled for the CPU here with OpenMP when threaded.
  `numpy` runs the same handler's numpy slice copies (serial); `builtin` is lbmpy's
  `builtin_periodicity` (wrapped indices inside the kernel; pystencils cannot vectorise them,
  so only with `--isa none`); `sync` is the data handling's full ghost-layer copy the previous
  peer used. Alternated at 64^3 on one thread (loaded host): kernel 2.97-2.98 MLUPS, numpy
  2.27-2.74, sync 1.28-1.95. Every periodicity and ISA gives the same field (mean u^2 equal
  to 12 digits after 20 steps from a seeded disturbance, `--check-steps 20`).
- SIMD: pystencils' intrinsic vectoriser (`cpu.vectorize`, inner stride one, unaligned
  loads), `--isa avx512` (8 lanes), `avx2` (4 lanes) or `none` (g++'s own
  auto-vectorisation only). The default `--isa avx512,avx2` compiles both vector kernels,
  times them in alternated bursts and reports the faster, so the peer gets its best
  instruction set per problem and thread count.
- OpenMP: on where OMP_NUM_THREADS > 1 (kernel, copy kernels and boundary kernel), off on one
  thread (`--openmp on` forces it on one thread too).
- Streaming: pull, two arrays (lbmpy's default). lbmpy's in-place AA pattern (one array, even
  and odd kernels) was tried: as set up here (periodicity handler and boundary handling given
  the previous step's parity) it did not reproduce the pull kernel's field on a disturbed
  periodic box (mean u^2 after 20 steps 6.63e-10 against 7.83e-10, with lbmpy's numpy
  handler and with the copy kernels alike), so it is not timed. pystencils' non-temporal
  stores (`use_nontemporal_stores`) were not tried.
- Simplifications: lbmpy's default strategy for the method, `pre_simplification` on (its
  default), `cse_global` on (`--no-cse-global` to drop it). lbmpy's `split` (inner-loop
  splitting) raises NotImplementedError in pystencils 2.0 and is not available.
- Boundary setup: with cython installed pystencils compiles its index-list builder; without
  it the pure-Python builder takes minutes on a 96^3 mask (setup only, not timed).
"""
import argparse
import itertools
import os
import time

ap = argparse.ArgumentParser()
ap.add_argument("--stencil", default="D3Q19")
ap.add_argument("--method", default="srt", choices=["srt", "trt"])
ap.add_argument("--n", type=int, default=64)
ap.add_argument("--mask", help="uint8 .npy mask, shape (nz, ny, nx), 1 = solid")
ap.add_argument("--seconds", type=float, default=2.0)
ap.add_argument("--periodic", default="kernel",
                help="comma list of kernel, numpy, builtin, sync")
ap.add_argument("--isa", default="avx512,avx2", help="comma list of avx512, avx2, none")
ap.add_argument("--openmp", default="auto", choices=["auto", "on", "off"])
ap.add_argument("--check-steps", type=int, default=0,
                help="run each variant this many (even) steps, print the mean velocity, stop")
ap.add_argument("--rounds", type=int, default=3,
                help="timed bursts of seconds / rounds per variant, the variants taking turns")
ap.add_argument("--no-cse-global", action="store_true")
ap.add_argument("--check", action="store_true",
                help="also print the mean fluid velocity after the timed steps (the open box: "
                "F (t + 1/2) after t steps)")
a = ap.parse_args()

import numpy as np
import pystencils as ps
from pystencils import Assignment, AssignmentCollection, CreateKernelConfig, Target
from lbmpy import ForceModel, LBMConfig, LBMOptimisation, LBStencil, Method, Stencil
from lbmpy import create_lb_function
from lbmpy.advanced_streaming.communication import get_communication_slices
from lbmpy.advanced_streaming.utility import Timestep

threads = int(os.environ.get("OMP_NUM_THREADS", "1"))
openmp = threads > 1 if a.openmp == "auto" else a.openmp == "on"
stencil = LBStencil(Stencil.D3Q15 if a.stencil.upper() == "D3Q15" else Stencil.D3Q19)
method = Method.SRT if a.method == "srt" else Method.TRT
omega = 1.0
rr = [omega] if method == Method.SRT else [omega, 1.0 / (0.5 + (3.0 / 16.0) / (1.0 / omega - 0.5))]
force = (1e-6, 0.0, 0.0)

if a.mask:
    mask_zyx = np.load(a.mask)
    solid = np.ascontiguousarray(mask_zyx.transpose(2, 1, 0)).astype(bool)  # indexed [x, y, z]
else:
    solid = None
shape = solid.shape if solid is not None else (a.n,) * 3
fluid_cells = int(shape[0] * shape[1] * shape[2] - (solid.sum() if solid is not None else 0))


def kernel_config(isa):
    target = {"avx512": Target.X86_AVX512, "avx2": Target.X86_AVX, "none": Target.CPU}[isa]
    cfg = CreateKernelConfig(target=target)
    cfg.cpu.openmp.enable = openmp
    if openmp:
        cfg.cpu.openmp.num_threads = threads
    if isa != "none":
        cfg.cpu.vectorize.enable = True
        cfg.cpu.vectorize.assume_inner_stride_one = True
    return cfg


def copy_kernels(dh, name, cfg):
    """lbmpy's periodicity handling as compiled kernels: one kernel per face and edge copying
    the populations that cross it (lbmpy's `get_communication_slices` for the pull pattern,
    the assignment of its `periodic_pdf_gpu_copy_kernel`, on the CPU target)."""
    field = dh.fields[name]
    comm = [d for d in itertools.product([-1, 0, 1], repeat=3) if any(d)]
    full = tuple(s + 2 for s in shape)
    kernels = []
    for _, slices in get_communication_slices(stencil, comm, "pull", Timestep.BOTH, 1).items():
        groups = {}  # the populations of one source/destination pair, keyed by its repr
        for src, dst in slices:
            groups.setdefault(repr((src[:-1], dst[:-1])), (src[:-1], dst[:-1], []))[2].append(src[-1])
        for src, dst, qs in groups.values():
            lo = [ps.slicing.normalize_slice(src, full), ps.slicing.normalize_slice(dst, full)]
            start = lambda s: s.start if isinstance(s, slice) else s
            offset = tuple(start(s1) - start(s2) for s1, s2 in zip(*lo))
            ac = AssignmentCollection([Assignment(field(q), field[offset](q)) for q in qs])
            kcfg = CreateKernelConfig(target=Target.CPU, iteration_slice=dst,
                                      skip_independence_check=True)
            kcfg.cpu.openmp.enable = cfg.cpu.openmp.enable
            if openmp:
                kcfg.cpu.openmp.num_threads = threads
            kernels.append(ps.create_kernel(ac, config=kcfg).compile())
    return kernels


def build(isa, periodic_kind):
    """One step of the chosen configuration, and a function giving the mean fluid velocity
    and the steps taken."""
    dh = ps.create_data_handling(shape, periodicity=True, default_target=Target.CPU)
    src = dh.add_array("src", values_per_cell=stencil.Q, layout="fzyx")
    dst = dh.add_array_like("dst", "src")
    builtin = periodic_kind == "builtin"
    opt = LBMOptimisation(symbolic_field=src, symbolic_temporary_field=dst,
                          cse_global=not a.no_cse_global, pre_simplification=True,
                          builtin_periodicity=(builtin,) * 3)
    lcfg = LBMConfig(stencil=stencil, method=method, relaxation_rates=rr, compressible=True,
                     force_model=ForceModel.GUO, force=force)
    kernel = create_lb_function(lbm_config=lcfg, lbm_optimisation=opt, config=kernel_config(isa))
    lb_method = kernel.method
    for q, w in enumerate(lb_method.weights):  # equilibrium at rest
        dh.cpu_arrays["src"][..., q] = float(w)
    if a.check_steps:  # a seeded disturbance, the same in every variant
        rng = np.random.default_rng(7)
        dh.cpu_arrays["src"][...] *= 1.0 + 0.01 * rng.random(dh.cpu_arrays["src"].shape)
    dh.cpu_arrays["dst"][...] = dh.cpu_arrays["src"]

    if periodic_kind == "kernel":
        copies = copy_kernels(dh, "src", kernel_config(isa))

        def periodic():
            arr = dh.cpu_arrays["src"]  # swapped with dst every step
            for k in copies:
                k(src=arr)
    elif periodic_kind == "numpy":
        from lbmpy.advanced_streaming import LBMPeriodicityHandling
        periodic = LBMPeriodicityHandling(stencil, dh, "src")
    elif periodic_kind == "sync":
        periodic = dh.synchronization_function(["src"])
    else:
        def periodic():
            pass

    boundary = lambda: None
    if solid is not None:
        from lbmpy.boundaries import LatticeBoltzmannBoundaryHandling, NoSlip
        bh = LatticeBoltzmannBoundaryHandling(lb_method, dh, "src", target=Target.CPU,
                                              openmp=openmp)
        wrapped = np.pad(solid, 1, mode="wrap")  # periodic images in the ghost layer
        bh.set_boundary(NoSlip(), mask_callback=lambda x, y, z: wrapped)
        bh.prepare()
        boundary = bh

    taken = [0]

    def step():
        periodic()
        boundary()
        dh.run_kernel(kernel)
        dh.swap("src", "dst")
        taken[0] += 1

    def mean_velocity():
        """The mean x velocity (sum_q c_qx f_q + F_x / 2) / rho over the fluid cells (with
        --check-steps its square's mean)."""
        f = dh.gather_array("src")
        rho = f.sum(axis=-1)
        ux = (sum(c[0] * f[..., q] for q, c in enumerate(stencil)) + force[0] / 2) / rho
        if a.check_steps:  # a statistic that depends on where the momentum went
            ux = ux * ux
        return float(ux[~solid].mean() if solid is not None else ux.mean()), taken[0]

    return step, mean_velocity


def timed(step, seconds):
    """MLUPS of a burst of at least `seconds` and two steps."""
    steps, t0 = 0, time.perf_counter()
    while steps < 2 or time.perf_counter() - t0 < seconds:
        step()
        steps += 1
    return fluid_cells * steps / (time.perf_counter() - t0) / 1e6


variants = [(i, k) for i in a.isa.split(",") for k in a.periodic.split(",")]
if a.check_steps:  # the same number of steps in every variant, then the mean velocity
    for v in variants:
        step, mean_velocity = build(*v)
        for _ in range(a.check_steps):
            step()
        print("# %s: mean ux^2 %.12e after %d steps" % (("/".join(v),) + mean_velocity()))
    raise SystemExit(0)

built = {}
for v in variants:
    step, mean_velocity = build(*v)
    step()  # warm-up
    built[v] = (step, mean_velocity)
best_of = {v: 0.0 for v in variants}
for _ in range(a.rounds):  # the variants take turns, so that load on the host hits all alike
    for v, (step, _) in built.items():
        best_of[v] = max(best_of[v], timed(step, a.seconds / a.rounds))
best = max(best_of, key=best_of.get)
print(f"MLUPS {best_of[best]:.4f}")
print("# " + ", ".join(f"{'/'.join(v)} {m:.2f}" for v, m in best_of.items())
      + f"; best {'/'.join(best)}, openmp {openmp} ({threads}),"
      + f" cse_global {not a.no_cse_global}, fluid cells {fluid_cells}"
      + "".join(f"; {'/'.join(v)} mean ux %.6e after %d steps" % mv()
                for v, (_, mv) in built.items() if a.check))
