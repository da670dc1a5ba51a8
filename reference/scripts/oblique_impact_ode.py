#!/usr/bin/env python3
"""Oblique impact of a sphere on a flat wall with a soft Hertz-Mindlin contact and normal
damping: the tangential impulse J_t / (mu J_n) of the contact's own equations of motion,
integrated without porelab code. Rerun: python3 reference/scripts/oblique_impact_ode.py
(writes reference/oblique_impact_ode.csv; plain Python, about a minute on one core).

Why: for a rigid body with Coulomb friction sliding throughout the contact, J_t = mu J_n
exactly (Maw, Barber & Fawcett 1976). A soft contact with a normal dashpot does not slide at
its onset: the dashpot force ~ delta^(1/4) sets a Coulomb limit mu F_n that the Mindlin spring
(~ delta^(3/2)) cannot reach at first, so the contact sticks and J_t / (mu J_n) < 1. This
script gives that ratio for the contact law itself (seed 002 Table 1 and eq. 1, in the
LAMMPS / LIGGGHTS form named below), to compare a DEM code against at its own time step.

The contact (SI): a sphere of radius R = 1 mm, density 2500 kg/m^3, Young's modulus 1e8 Pa,
Poisson ratio 0.3, on a wall of the same material, no gravity, impact speed 1 m/s at angle
theta from the normal, no spin.
- E* from 1/E* = 2 (1 - nu^2)/E, G* from 1/G* = 2 * 2 (2 - nu)(1 + nu)/E; R* = R, m* = m.
- overlap delta = R - z; S_n = 2 E* sqrt(R* delta); F_el = (2/3) S_n delta (Hertz).
- normal dashpot (restitution form, Tsuji et al. 1992 as in LIGGGHTS / LAMMPS
  `damping coeff_restitution`): eta_n = -2 beta sqrt((5/6) S_n m*),
  beta = ln e / sqrt(ln^2 e + pi^2).
- the normal force never pulls (LAMMPS `limit_damping`, LIGGGHTS `limitForce`):
  F_n = max(F_el - eta_n v_z, 0).
- tangential (LAMMPS `tangential mindlin`): k_t = 8 G* sqrt(R* delta), eta_t = ratio * eta_n,
  xi' = v_t (the slip velocity of the contact point, v_x - R w_y), trial F_t = -k_t xi - eta_t
  v_t; where |F_t| > mu F_n the contact slides: F_t = mu F_n along the trial force, and the
  spring carries the limit alone, xi = -F_t / k_t (no-tension limit: the dashpot adds nothing).
- motion: m v_x' = F_t, m v_z' = F_n, (2/5) m R^2 w_y' = -R F_t.
The stick phase is an ODE in (z, v_z, x, v_x, w_y, xi); the Coulomb limit is a projection of
xi (a sweeping process). Integration: classical RK4 on the smooth right-hand side with xi
projected after each step, at steps t_c / N for N = 2e4, 4e4 and 8e4 (t_c the Hertz contact
time at the normal speed), and Richardson extrapolation over the last two assuming first order
(the projection is first order at a transition); the printed convergence shows the order.
The restitution e used in the threshold tan(theta) = k (7/2) mu (1 + e) is the head-on
restitution of the same law, integrated the same way.
"""
import csv
import math
import os

R = 1e-3
RHO = 2500.0
E_YOUNG = 1e8
NU = 0.3
V = 1.0
M = RHO * 4.0 / 3.0 * math.pi * R**3
I = 0.4 * M * R * R
E_STAR = 1.0 / (2.0 * (1.0 - NU * NU) / E_YOUNG)
G_STAR = 1.0 / (2.0 * 2.0 * (2.0 - NU) * (1.0 + NU) / E_YOUNG)


def beta_of(e):
    l = math.log(e)
    return l / math.sqrt(l * l + math.pi * math.pi)


def hertz_tc(vn):
    """Hertz contact time (Johnson 1985 sec. 11.4): 2.868 (m*^2 / (R* E*^2 v))^(1/5)."""
    integral = 0.4 * math.gamma(0.4) * math.gamma(0.5) / math.gamma(0.9)
    c = 2.0 * (15.0 / 16.0) ** 0.4 * integral
    return c * (M * M / (R * E_STAR * E_STAR * vn)) ** 0.2


def forces(state, xi, beta, mu, ratio):
    """(F_n, trial F_t before the limit, k_t, limit) at a state in contact."""
    z, vz, vx, wy = state[0], state[1], state[2], state[3]
    delta = R - z
    if delta <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    s_n = 2.0 * E_STAR * math.sqrt(R * delta)
    f_el = 2.0 / 3.0 * s_n * delta
    eta_n = -2.0 * beta * math.sqrt(5.0 / 6.0 * s_n * M)
    f_n = max(f_el - eta_n * vz, 0.0)
    k_t = 8.0 * G_STAR * math.sqrt(R * delta)
    vt = vx - R * wy
    trial = -k_t * xi - ratio * eta_n * vt
    return f_n, trial, k_t, mu * f_n


def rhs(y, beta, mu, ratio):
    """Time derivative of (z, v_z, v_x, w_y, xi) with the Coulomb limit applied to the force."""
    z, vz, vx, wy, xi = y
    f_n, f_t, _, limit = forces(y, xi, beta, mu, ratio)
    if abs(f_t) > limit:
        f_t = math.copysign(limit, f_t)
    vt = vx - R * wy
    return (vz, f_n / M, f_t / M, -R * f_t / I, vt)


def impact(theta, e, mu, ratio, n_per_tc):
    """(J_n, J_t, R w after, restitution) of one impact, RK4 at t_c / n_per_tc."""
    beta = beta_of(e)
    vn, vt = V * math.cos(theta), V * math.sin(theta)
    dt = hertz_tc(vn) / n_per_tc
    y = [R, -vn, vt, 0.0, 0.0]
    for _ in range(int(20 * n_per_tc)):
        k1 = rhs(y, beta, mu, ratio)
        y2 = [a + 0.5 * dt * b for a, b in zip(y, k1)]
        k2 = rhs(y2, beta, mu, ratio)
        y3 = [a + 0.5 * dt * b for a, b in zip(y, k2)]
        k3 = rhs(y3, beta, mu, ratio)
        y4 = [a + dt * b for a, b in zip(y, k3)]
        k4 = rhs(y4, beta, mu, ratio)
        y = [a + dt / 6.0 * (b + 2 * c + 2 * d + f) for a, b, c, d, f in zip(y, k1, k2, k3, k4)]
        # the Coulomb limit on the spring: xi carries the limit alone while sliding
        f_n, f_t, k_t, limit = forces(y, y[4], beta, mu, ratio)
        if k_t > 0.0 and abs(f_t) > limit:
            y[4] = -math.copysign(limit, f_t) / k_t
        if y[0] >= R and y[1] > 0.0:
            z, vz, vx, wy, _ = y
            return M * (vz + vn), M * (vt - vx), R * wy, vz / vn
    raise RuntimeError("the contact did not end")


def converged(f, ns):
    """Values at the step counts ns and the first-order Richardson extrapolation of the last two."""
    vals = [f(n) for n in ns]
    a, b = vals[-2], vals[-1]
    return vals, 2.0 * b - a


def main():
    ns = [20000, 40000, 80000]
    rows = []
    for mu, e_req, ratio, over in [
        (0.3, 0.5, 0.0, 1.1),
        (0.3, 0.5, 0.0, 2.0),
        (0.3, 0.5, 1.0, 1.1),
        (0.3, 0.5, 1.0, 2.0),
    ]:
        e_vals, e = converged(lambda n: impact(0.0, e_req, mu, ratio, n)[3], ns)
        theta = math.atan(over * 3.5 * mu * (1.0 + e))

        def ratio_at(n):
            jn, jt, _, _ = impact(theta, e_req, mu, ratio, n)
            return jt / (mu * jn)

        r_vals, r = converged(ratio_at, ns)
        print(
            f"mu {mu} e_req {e_req} eta_t/eta_n {ratio} {over} x threshold: head-on e "
            f"{[f'{x:.8f}' for x in e_vals]} -> {e:.8f}; J_t/(mu J_n) "
            f"{[f'{x:.8f}' for x in r_vals]} -> {r:.8f}"
        )
        rows.append((mu, e_req, ratio, over, e, r, abs(r - r_vals[-1])))
    out = os.path.join(os.path.dirname(__file__), "..", "oblique_impact_ode.csv")
    with open(out, "w", newline="") as fh:
        fh.write("# reference/scripts/oblique_impact_ode.py: soft Hertz-Mindlin contact ODE, RK4 + projection, Richardson over t_c/4e4 and t_c/8e4\n")
        w = csv.writer(fh)
        w.writerow(["mu", "restitution", "tangential_damping_ratio", "tan_theta_over_threshold", "head_on_restitution", "jt_over_mu_jn", "extrapolation_change"])
        for row in rows:
            w.writerow([row[0], row[1], row[2], row[3], f"{row[4]:.10f}", f"{row[5]:.10f}", f"{row[6]:.2e}"])


if __name__ == "__main__":
    main()
