#!/usr/bin/env python3
"""Deterministic capture of a magnetic particle by one long wire (Watson, J. Appl. Phys. 44,
4209 (1973)): the capture half-width y_c against the ratio of magnetic to flow velocity, by an
independent trajectory integration in the closed-form field of an infinite, transversely
magnetized cylinder, in potential flow and in Kuwabara's cell-model Stokes flow. No porelab
code is used. Rerun: python3 reference/scripts/watson_capture_scipy.py (writes
reference/watson_capture.csv; numpy + scipy; a few minutes on one core).

Set-up (lengths in units of the wire radius b, velocities in units of the far flow U):
- wire: infinite circular cylinder r <= 1 along x, uniformly magnetized M along z (saturated,
  or soft iron in a field along z); the flow and the applied field H0 are along +z
  (Watson's longitudinal configuration). Outside (2-D dipole of a uniformly magnetized infinite
  cylinder, demagnetizing factor 1/2): H/M = h0 z^ + (1/(2 r^2)) (2 (z^.r^) r^ - z^),
  h0 = H0 / M.
- particle: a point with a moment of fixed magnitude m along H (saturated), so
  F = mu0 m (H^.grad) H = mu0 m grad|H| (curl H = 0); its magnetic velocity is
  v_m = (mobility mu0 m M / b) grad_r (|H| / M) = (V_m / U) grad(|H|/M) in these units.
- capture: the centre comes within 1 + R of the axis (R = particle radius / b, interception).
- potential flow: psi = (r - 1/r) sin(theta); start far upstream (z = -300) at offset y0,
  whose stream function is y0 (1 - 1/r0^2); the magnetic drift neglected upstream of the
  start moves a particle sideways by about (V_m/U) / (2 * 300^2), at most 6e-4 here.
- Kuwabara flow (solid fraction alpha, cell radius 1/sqrt(alpha)):
  psi = r sin(theta) / (2 Ku) [2 ln r - 1 + alpha + (1 - alpha/2)/r^2 - alpha r^2 / 2],
  Ku = -ln(alpha)/2 - 3/4 + alpha - alpha^2/4; psi = r sin(theta) on the cell boundary, where
  the particle starts (upstream side, offset y0); it passes when it leaves the cell again.
In both flows the single-wire efficiency eta = y_c is the stream function of the limiting start.
y_c is found by bisection on y0 after a scan checks that the captured offsets form one interval
[0, y_c]. Self-checks: with V_m = 0 the interception closed forms (potential:
1 + R - 1/(1 + R); Kuwabara: psi(1 + R, 90 deg)).
"""
import csv
import math
import os

import numpy as np
from scipy.integrate import solve_ivp

H0_OVER_M = 0.8
R_PARTICLE = 0.01
RATIOS = [0.0, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0]
FLOWS = [("potential", 0.0), ("kuwabara", 0.05)]
Z_FAR = 300.0


def grad_abs_h(y, z):
    """grad |H|/M at (y, z) (x along the wire drops out), by the closed form of H."""
    r2 = y * y + z * z
    r4 = r2 * r2
    # H/M = h0 z^ + (1/(2 r^2)) (2 (z/r) r^ - z^): components
    # Hy = y z / r^4, Hz = h0 + (z^2 - y^2) / (2 r^4)
    hy = y * z / r4
    hz = H0_OVER_M + (z * z - y * y) / (2.0 * r4)
    # derivatives
    r6 = r4 * r2
    dhy_dy = z / r4 - 4.0 * y * y * z / r6
    dhy_dz = y / r4 - 4.0 * y * z * z / r6
    dhz_dy = -y / r4 - 2.0 * y * (z * z - y * y) / r6
    dhz_dz = z / r4 - 2.0 * z * (z * z - y * y) / r6
    n = math.hypot(hy, hz)
    return (hy * dhy_dy + hz * dhz_dy) / n, (hy * dhy_dz + hz * dhz_dz) / n


def kuwabara_constant(alpha):
    return -0.5 * math.log(alpha) - 0.75 + alpha - 0.25 * alpha * alpha


def flow(kind, alpha, y, z):
    """(u_y, u_z) of the flow along +z past the wire, in units of U."""
    r2 = y * y + z * z
    r = math.sqrt(r2)
    # polar angle theta from +z (the flow direction) toward +y: y = r sin, z = r cos
    s, c = y / r, z / r
    if kind == "potential":
        # psi = (r - 1/r) sin: u_r = (1/r) dpsi/dtheta, u_t = -dpsi/dr (theta from -z upstream
        # convention avoided: we use theta from +z, psi = U y far away)
        f = r - 1.0 / r
        df = 1.0 + 1.0 / r2
    else:
        ku = kuwabara_constant(alpha)
        f = r / (2 * ku) * (2 * math.log(r) - 1 + alpha + (1 - alpha / 2) / r2 - alpha * r2 / 2)
        df = (1 / (2 * ku)) * (
            2 * math.log(r) - 1 + alpha + (1 - alpha / 2) / r2 - alpha * r2 / 2
        ) + r / (2 * ku) * (2 / r - 2 * (1 - alpha / 2) / (r2 * r) - alpha * r)
    # psi = f(r) sin(theta); with theta from +z, u_r = (1/r) dpsi/dtheta = f cos / r,
    # u_theta = -dpsi/dr = -f' sin  (far away: u_r = cos, u_theta = -sin -> u = +z^)
    ur = f * c / r
    ut = -df * s
    # r^ = (s, c), theta^ = (c, -s) in (y, z)
    return ur * s + ut * c, ur * c - ut * s


def captured(kind, alpha, ratio, y0):
    rc = 1.0 + R_PARTICLE
    if kind == "potential":
        start = [y0, -Z_FAR]
        r_out = None
    else:
        r_cell = 1.0 / math.sqrt(alpha)
        start = [y0, -math.sqrt(r_cell * r_cell - y0 * y0)]
        r_out = r_cell

    def rhs(_t, p):
        uy, uz = flow(kind, alpha, p[0], p[1])
        gy, gz = grad_abs_h(p[0], p[1])
        return [uy + ratio * gy, uz + ratio * gz]

    def hit(_t, p):
        return math.hypot(p[0], p[1]) - rc

    hit.terminal = True

    def gone(_t, p):
        if r_out is None:
            return Z_FAR - p[1]
        # leaving the cell downstream (z > 0)
        return r_out * (1 + 1e-9) - math.hypot(p[0], p[1]) if p[1] > 0 else 1.0

    gone.terminal = True

    def closest(_t, p):
        # r dr/dt: its rise through zero is a closest approach; a grazing approach can dip
        # below 1 + R inside one step without the hit event changing sign at the step ends
        v = rhs(_t, p)
        return p[0] * v[0] + p[1] * v[1]

    closest.direction = 1
    sol = solve_ivp(
        rhs,
        [0.0, 1e5],
        start,
        events=[hit, gone, closest],
        rtol=1e-10,
        atol=1e-12,
        max_step=0.5,
    )
    if sol.t_events[0].size:
        return True
    if any(math.hypot(q[0], q[1]) <= rc for q in sol.y_events[2]):
        return True
    if sol.t_events[1].size:
        return False
    raise RuntimeError(f"trajectory {kind} ratio {ratio} y0 {y0}: neither captured nor passed")


def capture_half_width(kind, alpha, ratio):
    y_max = 0.999 / math.sqrt(alpha) if kind == "kuwabara" else 40.0
    scan = np.linspace(1e-6, min(y_max, 12.0), 61)
    hits = [captured(kind, alpha, ratio, y) for y in scan]
    # one interval [0, y_c]: captured up to a point, passed beyond
    k = hits.index(False) if False in hits else len(hits)
    if any(hits[k:]):
        raise RuntimeError(f"{kind} ratio {ratio}: the captured offsets are not one interval")
    if k == len(hits):
        return float("inf")
    if k == 0:
        return 0.0
    lo, hi = scan[k - 1], scan[k]
    for _ in range(45):
        mid = 0.5 * (lo + hi)
        if captured(kind, alpha, ratio, mid):
            lo = mid
        else:
            hi = mid
    y0 = 0.5 * (lo + hi)
    if kind == "potential":
        # the stream function of the start point (y0, -Z_FAR)
        return y0 * (1.0 - 1.0 / (y0 * y0 + Z_FAR * Z_FAR))
    return y0


def main():
    rows = []
    for kind, alpha in FLOWS:
        for ratio in RATIOS:
            yc = capture_half_width(kind, alpha, ratio)
            rows.append((kind, alpha, H0_OVER_M, R_PARTICLE, ratio, yc))
            print(kind, alpha, ratio, yc, flush=True)
    # self-checks against the interception closed forms (V_m = 0): the stream function at
    # r = 1 + R, theta = 90 degrees
    r1 = 1.0 + R_PARTICLE
    for kind, alpha, _, _, ratio, yc in rows:
        if ratio == 0.0:
            if kind == "potential":
                want = r1 - 1.0 / r1
            else:
                ku = kuwabara_constant(alpha)
                want = r1 / (2 * ku) * (
                    2 * math.log(r1) - 1 + alpha + (1 - alpha / 2) / r1**2 - alpha * r1**2 / 2
                )
            err = abs(yc - want) / want
            print(f"interception check {kind}: {yc:.12g} vs {want:.12g} ({err:.1e})")
            assert err < 1e-7, kind
    out = os.path.join(os.path.dirname(__file__), "..", "watson_capture.csv")
    with open(out, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["flow", "solid_fraction", "h0_over_m", "particle_radius_over_b",
                    "vm_over_u", "capture_half_width_over_b"])
        for row in rows:
            w.writerow([row[0], row[1], row[2], row[3], repr(float(row[4])), repr(float(row[5]))])
    print("wrote", os.path.normpath(out))


if __name__ == "__main__":
    main()
