//! Cases 701-708: the DEM engine (seed 002) against closed forms of contact mechanics and
//! rigid-body motion: head-on collisions (linear spring–dashpot, Hertz, restitution-damped
//! Hertz), sphere–wall contact time, sliding to rolling, incline motion, Stokes settling with
//! the integrator's order, energy conservation without damping and the floor force of a static
//! bed. Expected values are computed here from the closed forms (or, for the damped Hertz
//! restitution, by an independent fine-step RK4 of the contact ODE), never by the engine.

use crate::dem::{
    setup::auto_time_step, ContactModel, CoulombLimit, DampingModel, Dem, Drag, ImpactSpeed,
    Material, NormalModel, PairMaterial, Particles, Rest, Setup, Start, StopRule, TangentialModel,
    TimeStep,
};
use crate::validation::{CaseContext, Row};
use crate::{Error, Result};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use std::f64::consts::PI;

const RHO: f64 = 2500.0;

/// A box l x l x h (fixed top wall) holding particles `p`, no drivers, the automatic time
/// step at impact speed `v` (m/s).
pub(super) fn setup(
    contact: ContactModel,
    mat: Material,
    wall: Material,
    l: f64,
    h: f64,
    p: Particles,
    v: f64,
) -> Setup {
    let mut s = Setup::in_box([l, l, h], contact, mat, RHO, Start::Given(p));
    s.wall_material = wall;
    s.impact_speed = ImpactSpeed::Given { m_s: v };
    s
}

fn model_from_row(t: &crate::validation::Table, i: usize) -> Result<ContactModel> {
    let e = t.f64(i, "restitution")?;
    let normal = match t.str(i, "normal")? {
        "hertz" => NormalModel::Hertz,
        "linear" => NormalModel::Linear {
            k_n_n_per_m: t.f64(i, "k_n_N_per_m")?,
        },
        other => return Err(Error::Validation(format!("unknown normal model `{other}`"))),
    };
    // the closed forms and the RK4 of cases 701-703 are those of the law whose dashpot may
    // pull at the end of a contact (smooth in time, so the errors fall as dt^2); the default
    // no-tension law is checked by case 714
    Ok(
        ContactModel::new(normal, DampingModel::restitution(e)?, TangentialModel::None)?
            .with_limit(CoulombLimit::DashpotInLimit),
    )
}

/// Sphere mass (kg).
pub(super) fn mass(r: f64) -> f64 {
    RHO * 4.0 / 3.0 * PI * r.powi(3)
}

/// Exact Hertz contact-time constant: t_c = c (m*^2 / (R* E*^2 v))^(1/5) with
/// c = 2 (15/16)^(2/5) * (2/5) B(2/5, 1/2) (2.868 to four digits; Johnson 1985 sec. 11.4).
pub(super) fn hertz_constant() -> f64 {
    use statrs::function::gamma::gamma;
    let integral = 0.4 * gamma(0.4) * gamma(0.5) / gamma(0.9);
    2.0 * (15.0f64 / 16.0).powf(0.4) * integral
}

/// A head-on impact at relative speed v of two equal spheres (radius r, along x) or of a
/// sphere on the floor (along z). Returns (restitution, contact time): the contact time is
/// measured from the exact touching time of the free flight to the overlap's zero crossing,
/// interpolated linearly between the two steps around it.
pub(super) fn impact(
    model: ContactModel,
    mat: Material,
    wall: Material,
    r: f64,
    v: f64,
    dt: f64,
    on_wall: bool,
) -> Result<(f64, f64)> {
    impact_from_gap(model, mat, wall, r, v, dt, on_wall, 0.1 * r)
}

/// [`impact`] of two equal spheres from a gap chosen so that the contact starts at the
/// fraction `phase` of a step: gap = v dt (floor(0.1 r / (v dt)) + phase). Impacts at the same
/// dt / t_c and phase are the same discrete problem in reduced units when the law is
/// self-similar in v.
pub(super) fn pair_impact_at_phase(
    model: ContactModel,
    mat: Material,
    r: f64,
    v: f64,
    dt: f64,
    phase: f64,
) -> Result<(f64, f64)> {
    let gap = v * dt * ((0.1 * r / (v * dt)).floor() + phase);
    impact_from_gap(model, mat, mat, r, v, dt, false, gap)
}

#[allow(clippy::too_many_arguments)]
fn impact_from_gap(
    model: ContactModel,
    mat: Material,
    wall: Material,
    r: f64,
    v: f64,
    dt: f64,
    on_wall: bool,
    gap: f64,
) -> Result<(f64, f64)> {
    let l = 100.0 * r;
    let (p, t0) = if on_wall {
        let mut p = Particles::at_rest(vec![Vector3::new(0.5 * l, 0.5 * l, r + gap)], vec![r], RHO);
        p.vel[0] = Vector3::new(0.0, 0.0, -v);
        (p, gap / v)
    } else {
        let mut p = Particles::at_rest(
            vec![
                Vector3::new(0.4 * l, 0.5 * l, 0.5 * l),
                Vector3::new(0.4 * l + 2.0 * r + gap, 0.5 * l, 0.5 * l),
            ],
            vec![r, r],
            RHO,
        );
        p.vel[0] = Vector3::new(0.5 * v, 0.0, 0.0);
        p.vel[1] = Vector3::new(-0.5 * v, 0.0, 0.0);
        (p, gap / v)
    };
    let mut s = setup(model, mat, wall, l, l, p, v);
    s.time_step = TimeStep::Given { dt_s: dt };
    let mut dem = Dem::new(s)?;
    let overlap = |d: &Dem| {
        if on_wall {
            r - d.p.pos[0].z
        } else {
            2.0 * r - (d.p.pos[1] - d.p.pos[0]).norm()
        }
    };
    let mut touched = false;
    let mut prev = overlap(&dem);
    let limit = (100.0 * (t0 + 1.0) / dt) as u64;
    for _ in 0..limit.min(50_000_000) {
        dem.step()?;
        let now = overlap(&dem);
        if now > 0.0 {
            touched = true;
        } else if touched {
            let t_end = dem.time_s - dt * (-now) / (prev - now);
            let e = if on_wall {
                dem.p.vel[0].z / v
            } else {
                (dem.p.vel[1].x - dem.p.vel[0].x) / v
            };
            return Ok((e, t_end - t0));
        }
        prev = now;
    }
    Err(Error::Validation("impact: the contact did not end".into()))
}

/// Restitution of the contact ODE m* x'' = -F_el(x) - eta(x) x' (at most 0 under
/// [`CoulombLimit::NoTension`]) from x = 0, x' = v, by RK4
/// with `n` steps per estimated contact time (an oracle independent of the engine's
/// integrator; used for the damped Hertz law, which has no closed form).
pub(super) fn restitution_rk4(
    model: &ContactModel,
    pm: &PairMaterial,
    r_eff: f64,
    m_eff: f64,
    v: f64,
    tc: f64,
    n: usize,
) -> f64 {
    // eta_n = 2 (-beta) sqrt(c S_n m*) (restitution form) or c_n sqrt(6 m* S_n) (Zhou 2002)
    let (neg_beta, zhou_c_n) = match model.damping() {
        DampingModel::Restitution { neg_beta, .. } => (neg_beta, 0.0),
        DampingModel::None => (0.0, 0.0),
        DampingModel::Zhou { c_n } => (0.0, c_n),
    };
    let no_tension = model.limit() == CoulombLimit::NoTension;
    let accel = |x: f64, u: f64| -> f64 {
        if x <= 0.0 {
            return 0.0;
        }
        let (f, s) = match model.normal() {
            NormalModel::Hertz => {
                let s = 2.0 * pm.e_star_pa * (r_eff * x).sqrt();
                (s * x * 2.0 / 3.0, s)
            }
            NormalModel::Linear { k_n_n_per_m } => (k_n_n_per_m * x, k_n_n_per_m),
        };
        let c = if model.normal().is_hertz() {
            5.0 / 6.0
        } else {
            1.0
        };
        let eta = 2.0 * neg_beta * (c * s * m_eff).sqrt() + zhou_c_n * (6.0 * m_eff * s).sqrt();
        let push = f + eta * u;
        // without tension the dashpot never pulls: the force is max(F_el + eta x', 0)
        if no_tension && push < 0.0 {
            0.0
        } else {
            -push / m_eff
        }
    };
    let h = tc / n as f64;
    let (mut x, mut u) = (0.0, v);
    let mut k = 0;
    loop {
        let (k1x, k1u) = (u, accel(x, u));
        let (k2x, k2u) = (
            u + 0.5 * h * k1u,
            accel(x + 0.5 * h * k1x, u + 0.5 * h * k1u),
        );
        let (k3x, k3u) = (
            u + 0.5 * h * k2u,
            accel(x + 0.5 * h * k2x, u + 0.5 * h * k2u),
        );
        let (k4x, k4u) = (u + h * k3u, accel(x + h * k3x, u + h * k3u));
        let xn = x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
        let un = u + h / 6.0 * (k1u + 2.0 * k2u + 2.0 * k3u + k4u);
        k += 1;
        if xn <= 0.0 && k > 1 {
            // interpolate the velocity at the zero crossing
            let f = x / (x - xn);
            return -(u + f * (un - u)) / v;
        }
        x = xn;
        u = un;
        if k > 100 * n {
            return f64::NAN;
        }
    }
}

register!("701" => case_701);
/// Case 701: linear spring–dashpot head-on collision of two equal spheres. Each row of
/// expected.csv is one impact (restitution, speed, dt as a fraction of t_c); rows check e
/// against exp(-pi zeta / sqrt(1 - zeta^2)) (which the dashpot is built to give) and t_c
/// against pi / omega_d, omega_d = omega_0 sqrt(1 - zeta^2), omega_0 = sqrt(k_n / m*).
pub fn case_701(ctx: &CaseContext) -> Result<Vec<Row>> {
    collisions(ctx, false)
}

register!("703" => case_703);
/// Case 703: a sphere hitting the floor (a sphere of infinite radius and mass, its own
/// material): Hertz contact time with R* = R, m* = m and E* from the same rule as for pairs,
/// and the linear law's t_c with m* = m.
pub fn case_703(ctx: &CaseContext) -> Result<Vec<Row>> {
    collisions(ctx, true)
}

fn collisions(ctx: &CaseContext, on_wall: bool) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let model = model_from_row(&t, i)?;
        let r = t.f64(i, "radius_m")?;
        let v = t.f64(i, "speed_m_s")?;
        let mat = Material::new(t.f64(i, "young_Pa")?, t.f64(i, "poisson")?)?;
        let wall = Material::new(t.f64(i, "wall_young_Pa")?, t.f64(i, "wall_poisson")?)?;
        let frac = t.f64(i, "dt_over_tc")?;
        let m_eff = if on_wall { mass(r) } else { 0.5 * mass(r) };
        let r_eff = if on_wall { r } else { 0.5 * r };
        let pm = if on_wall {
            PairMaterial::new(&mat, &wall)
        } else {
            PairMaterial::new(&mat, &mat)
        };
        let e_req = t.f64(i, "restitution")?;
        let (tc, e_exp) = match model.normal() {
            NormalModel::Linear { k_n_n_per_m } => {
                let w0 = (k_n_n_per_m / m_eff).sqrt();
                let l = e_req.ln();
                let zeta = -l / (l * l + PI * PI).sqrt();
                (PI / (w0 * (1.0 - zeta * zeta).sqrt()), e_req)
            }
            NormalModel::Hertz => {
                let tc = hertz_constant()
                    * (m_eff * m_eff / (r_eff * pm.e_star_pa * pm.e_star_pa * v)).powf(0.2);
                let e = if e_req < 1.0 {
                    restitution_rk4(&model, &pm, r_eff, m_eff, v, tc, 200_000)
                } else {
                    1.0
                };
                (tc, e)
            }
        };
        let (e, tc_got) = impact(model, mat, wall, r, v, frac * tc, on_wall)?;
        let label = format!("{} e={e_req} v={v} dt=tc*{frac}", t.str(i, "normal")?);
        // allowed relative errors given at dt = t_c / 50, scaled as dt^2 (second order)
        let k2 = (frac / 0.02).powi(2);
        if t.str(i, "check")?.contains('e') {
            let tol = t.f64(i, "e_rel_tol_at_tc_over_50")? * k2;
            rows.push(Row::new(
                format!("{label} restitution"),
                e,
                e_exp,
                tol * e_exp,
            ));
        }
        if t.str(i, "check")?.contains('t') {
            let tol = t.f64(i, "tc_rel_tol_at_tc_over_50")? * k2;
            rows.push(Row::new(
                format!("{label} contact time"),
                tc_got,
                tc,
                tol * tc,
            ));
        }
    }
    Ok(rows)
}

register!("702" => case_702);
/// Case 702: restitution-damped Hertz (LIGGGHTS form): e does not depend on the impact speed
/// (the contact ODE is self-similar in v). Rows: e at each speed against e at the first speed
/// of the same (restitution, dt) group; and e against the fine-step RK4 of the contact ODE.
pub fn case_702(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    let mut first: Option<(String, f64)> = None;
    for i in 0..t.len() {
        let model = model_from_row(&t, i)?;
        let r = t.f64(i, "radius_m")?;
        let v = t.f64(i, "speed_m_s")?;
        let mat = Material::new(t.f64(i, "young_Pa")?, t.f64(i, "poisson")?)?;
        let frac = t.f64(i, "dt_over_tc")?;
        let (m_eff, r_eff) = (0.5 * mass(r), 0.5 * r);
        let pm = PairMaterial::new(&mat, &mat);
        let tc = hertz_constant()
            * (m_eff * m_eff / (r_eff * pm.e_star_pa * pm.e_star_pa * v)).powf(0.2);
        let (e, _) = impact(model, mat, mat, r, v, frac * tc, false)?;
        let group = format!("e={} dt=tc*{frac}", t.f64(i, "restitution")?);
        let tol = t.f64(i, "e_rel_tol")?;
        match &first {
            Some((g, e0)) if *g == group => {
                rows.push(Row::new(
                    format!("{group} v={v}: e(v)/e(v0)"),
                    e / e0,
                    1.0,
                    2.0 * tol,
                ));
            }
            _ => first = Some((group.clone(), e)),
        }
        let e_rk = restitution_rk4(&model, &pm, r_eff, m_eff, v, tc, 200_000);
        rows.push(Row::new(
            format!("{group} v={v}: e vs RK4"),
            e,
            e_rk,
            tol * e_rk,
        ));
    }
    Ok(rows)
}

/// Hertz–Mindlin sphere resting on the floor at its static overlap (3 m g_n / (4 E* sqrt R))^(2/3).
fn resting_sphere(r: f64, mu: f64, damp_ratio: f64, g: Vector3<f64>, v0: f64) -> Result<Dem> {
    let mat = Material::new(1e8, 0.3)?;
    let model = ContactModel::new(
        NormalModel::Hertz,
        DampingModel::restitution(0.5)?,
        TangentialModel::Mindlin { mu, damp_ratio },
    )?;
    let l = 40.0 * r;
    let pm = PairMaterial::new(&mat, &mat);
    let fz = mass(r) * (-g.z);
    let delta0 = (3.0 * fz / (4.0 * pm.e_star_pa * r.sqrt())).powf(2.0 / 3.0);
    let mut p = Particles::at_rest(
        vec![Vector3::new(0.5 * l, 0.5 * l, r - delta0)],
        vec![r],
        RHO,
    );
    p.vel[0] = Vector3::new(v0, 0.0, 0.0);
    let mut s = setup(model, mat, mat, l, l, p, 0.1);
    s.gravity_m_s2 = g;
    Dem::new(s)
}

register!("704" => case_704);
/// Case 704: a sphere launched sliding without spin on the floor with Coulomb friction mu:
/// slip v - R w decreases as v0 - (7/2) mu g t, so rolling starts at t = 2 v0 / (7 mu g), then
/// v = 5 v0 / 7 and w = v / R (angular momentum about the contact point is conserved).
pub fn case_704(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let (r, mu, v0, g) = (
            t.f64(i, "radius_m")?,
            t.f64(i, "mu")?,
            t.f64(i, "v0_m_s")?,
            t.f64(i, "g_m_s2")?,
        );
        let damp = t.f64(i, "tangential_damping_ratio")?;
        let check = t.str(i, "check")?.to_string();
        let mut dem = resting_sphere(r, mu, damp, Vector3::new(0.0, 0.0, -g), v0)?;
        let t_roll = 2.0 * v0 / (7.0 * mu * g);
        let slip = |d: &Dem| d.p.vel[0].x - r * d.p.omega[0].y;
        let mut prev = slip(&dem);
        let mut t_got = f64::NAN;
        let steps = (3.0 * t_roll / dem.dt_s()) as u64;
        for _ in 0..steps {
            dem.step()?;
            let s = slip(&dem);
            if t_got.is_nan() && s <= 0.0 {
                t_got = dem.time_s - dem.dt_s() * (-s) / (prev - s);
            }
            prev = s;
        }
        let v_end = dem.p.vel[0].x;
        let w_end = dem.p.omega[0].y;
        let label = format!("mu={mu} v0={v0} eta_t/eta_n={damp}");
        // onset within one step; final state to round-off (exact conservation, see below)
        let vtol = t.f64(i, "v_rel_tol")? * v0;
        if check.contains('t') {
            rows.push(Row::new(
                format!("{label} rolling onset time (within dt)"),
                t_got,
                t_roll,
                dem.dt_s(),
            ));
        }
        if check.contains('v') {
            rows.push(Row::new(
                format!("{label} final v"),
                v_end,
                5.0 * v0 / 7.0,
                vtol,
            ));
            rows.push(Row::new(
                format!("{label} final R w"),
                r * w_end,
                5.0 * v0 / 7.0,
                vtol,
            ));
        }
    }
    Ok(rows)
}

register!("705" => case_705);
/// Case 705: a sphere released at rest on a plane inclined by theta (gravity tilted): it rolls
/// with a = (5/7) g sin(theta) when tan(theta) <= (7/2) mu, else slides with
/// a = g (sin(theta) - mu cos(theta)). Acceleration from the velocity change over the second
/// half of the run.
pub fn case_705(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let (r, mu, th, g, dur) = (
            t.f64(i, "radius_m")?,
            t.f64(i, "mu")?,
            t.f64(i, "theta_deg")?.to_radians(),
            t.f64(i, "g_m_s2")?,
            t.f64(i, "duration_s")?,
        );
        let grav = Vector3::new(g * th.sin(), 0.0, -g * th.cos());
        let mut dem = resting_sphere(r, mu, 1.0, grav, 0.0)?;
        let steps = (dur / dem.dt_s()) as u64;
        dem.run(steps / 2)?;
        let (t1, v1) = (dem.time_s, dem.p.vel[0].x);
        dem.run(steps - steps / 2)?;
        let a = (dem.p.vel[0].x - v1) / (dem.time_s - t1);
        let rolls = th.tan() <= 3.5 * mu;
        let a_exp = if rolls {
            5.0 / 7.0 * g * th.sin()
        } else {
            g * (th.sin() - mu * th.cos())
        };
        rows.push(Row::new(
            format!(
                "theta={}deg mu={mu} {}",
                t.f64(i, "theta_deg")?,
                if rolls { "rolling" } else { "sliding" }
            ),
            a,
            a_exp,
            t.f64(i, "a_rel_tol")? * a_exp,
        ));
    }
    Ok(rows)
}

/// One sphere settling from rest under gravity, buoyancy and Stokes drag, far from walls:
/// the full-step velocity at time T against v_t (1 - exp(-T / tau)), tau = m / (6 pi mu a),
/// v_t = m (1 - rho_f / rho_p) g / (6 pi mu a).
fn settle(r: f64, mu: f64, rho_f: f64, g: f64, t_end: f64, dt: f64) -> Result<(f64, f64)> {
    // no contact happens; a soft material keeps the contact-time limit on dt above tau / 10
    let mat = Material::new(1e2, 0.3)?;
    let model = ContactModel::new(
        NormalModel::Hertz,
        DampingModel::None,
        TangentialModel::None,
    )?;
    let l = 10.0 * r;
    let h = 1e9 * r;
    let p = Particles::at_rest(vec![Vector3::new(0.5 * l, 0.5 * l, 0.5 * h)], vec![r], RHO);
    let mut s = setup(model, mat, mat, l, h, p, 1e-3);
    s.gravity_m_s2 = Vector3::new(0.0, 0.0, -g);
    s.fluid_density_kg_m3 = rho_f;
    s.drag = Some(Drag::new(mu, Vector3::zeros())?);
    s.time_step = TimeStep::Given { dt_s: dt };
    let mut dem = Dem::new(s)?;
    let n = (t_end / dt).round() as u64;
    dem.run(n)?;
    let m = mass(r);
    let c = 6.0 * PI * mu * r;
    let vt = m * (1.0 - rho_f / RHO) * g / c;
    let exact = -vt * (1.0 - (-dem.time_s * c / m).exp());
    Ok((dem.p.vel[0].z, exact))
}

register!("706" => case_706);
/// Case 706: Stokes settling; rows: the velocity at T = 3 tau for dt = tau / k (k and the
/// allowed relative error from expected.csv), and the observed order of the error between
/// consecutive step sizes (expected 2). Every row's scale is its allowed deviation (rtol = 1).
pub fn case_706(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    let mut errs = Vec::new();
    let (r, mu, rho_f, g) = (1e-4, 1e-3, 1000.0, 9.81);
    let tau = mass(r) / (6.0 * PI * mu * r);
    for i in 0..t.len() {
        let k = t.f64(i, "steps_per_tau")?;
        let (got, exact) = settle(r, mu, rho_f, g, 3.0 * tau, tau / k)?;
        let tol = t.f64(i, "rel_tolerance")?;
        rows.push(Row::new(
            format!("dt=tau/{k} v(3 tau)"),
            got,
            exact,
            tol * exact.abs(),
        ));
        errs.push((k, (got - exact).abs()));
    }
    let order_tol = t.f64(0, "order_tolerance")?;
    for w in errs.windows(2) {
        let order = (w[0].1 / w[1].1).ln() / (w[1].0 / w[0].0).ln();
        rows.push(Row::new(
            format!("order between dt=tau/{} and tau/{}", w[0].0, w[1].0),
            order,
            2.0,
            order_tol,
        ));
    }
    Ok(rows)
}

/// A gas of `n` elastic frictionless Hertz spheres in a box with walls, random velocities;
/// returns (max |E - E0| / E0 over the run, (E_end - E0) / E0, collisions).
fn gas(n: usize, seed: u64, dt_frac: f64, t_end: f64) -> Result<(f64, f64, usize)> {
    let r = 1e-3;
    let mat = Material::new(1e7, 0.3)?;
    let model = ContactModel::new(
        NormalModel::Hertz,
        DampingModel::None,
        TangentialModel::None,
    )?;
    let l = 12.0 * r;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let radius = vec![r; n];
    let pos = crate::dem::start::random_dispersion(&radius, l, l, l, &mut rng)?;
    let mut p = Particles::at_rest(pos, radius, RHO);
    for v in p.vel.iter_mut() {
        *v = Vector3::new(
            rng.gen::<f64>() - 0.5,
            rng.gen::<f64>() - 0.5,
            rng.gen::<f64>() - 0.5,
        );
    }
    let mut s = setup(model, mat, mat, l, l, p, 2.0);
    let dt0 = auto_time_step(&s, r, 2.0);
    s.time_step = TimeStep::Given {
        dt_s: dt0 * dt_frac,
    };
    let mut dem = Dem::new(s)?;
    let e0 = dem.kinetic_energy() + dem.normal_elastic_energy();
    let mut worst: f64 = 0.0;
    let steps = (t_end / dem.dt_s()) as u64;
    let mut contacts = 0usize;
    let mut was: Vec<bool> = Vec::new();
    for _ in 0..steps {
        dem.step()?;
        let e = dem.kinetic_energy() + dem.normal_elastic_energy();
        worst = worst.max((e - e0).abs() / e0);
        if was.len() != dem.nl.pairs.len() {
            was = vec![false; dem.nl.pairs.len()];
        }
        for (k, pr) in dem.nl.pairs.iter().enumerate() {
            let on = pr.delta > 0.0;
            if on && !was[k] {
                contacts += 1;
            }
            was[k] = on;
        }
    }
    let e = dem.kinetic_energy() + dem.normal_elastic_energy();
    Ok((worst, (e - e0) / e0, contacts))
}

register!("707" => case_707);
/// Case 707: energy without damping (elastic frictionless Hertz gas with walls): the largest
/// relative energy error and the end-to-start drift stay below the bounds of the table at the
/// automatic step, and the largest error falls with the order band of the table when dt is
/// halved (every row's scale is its allowed deviation).
pub fn case_707(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let seed = ctx.seed.unwrap_or(707);
    let n = t.f64(0, "n_spheres")? as usize;
    let t_end = t.f64(0, "duration_s")?;
    let bound = t.f64(0, "max_rel_energy_error")?;
    let drift = t.f64(0, "max_rel_drift")?;
    let (o_lo, o_hi) = (t.f64(0, "order_min")?, t.f64(0, "order_max")?);
    let (w1, d1, c1) = gas(n, seed, 1.0, t_end)?;
    let (w2, _, _) = gas(n, seed, 0.5, t_end)?;
    if c1 < 10 * n {
        return Err(Error::Validation(format!(
            "only {c1} contacts in the run; need many collisions"
        )));
    }
    let order = (w1 / w2).log2();
    Ok(vec![
        Row::new(
            format!("max |dE|/E0 at the automatic dt ({c1} contacts) below {bound}"),
            w1,
            0.0,
            bound,
        ),
        Row::new(
            format!("(E_end - E0)/E0 at the automatic dt below {drift}"),
            d1,
            0.0,
            drift,
        ),
        Row::new(
            format!("order of the max energy error (dt -> dt/2) in [{o_lo}, {o_hi}]"),
            order,
            0.5 * (o_lo + o_hi),
            0.5 * (o_hi - o_lo),
        ),
    ])
}

register!("708" => case_708);
/// Case 708: a bed settled under gravity on the floor of a periodic box: the floor's force
/// equals the buoyant weight N m (1 - rho_f / rho_p) g once the bed is at rest.
pub fn case_708(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let seed = ctx.seed.unwrap_or(708);
    let n = t.f64(0, "n_spheres")? as usize;
    let mu = t.f64(0, "mu")?;
    let rho_f = t.f64(0, "fluid_density_kg_m3")?;
    let r: f64 = 2e-4;
    let mat = Material::new(1e7, 0.3)?;
    let model = ContactModel::new(
        NormalModel::Hertz,
        DampingModel::restitution(0.3)?,
        TangentialModel::Mindlin {
            mu,
            damp_ratio: 1.0,
        },
    )?;
    let l = 8.0 * 2.0 * r;
    let h = (n as f64 * 4.0 / 3.0 * PI * r.powi(3)) / (0.25 * l * l);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let radius: Vec<f64> = (0..n).map(|_| r * (0.9 + 0.2 * rng.gen::<f64>())).collect();
    let pos = crate::dem::start::random_dispersion(&radius, l, l, h, &mut rng)?;
    let p = Particles::at_rest(pos, radius, RHO);
    let mut s = setup(model, mat, mat, l, h, p, (2.0 * 9.81 * h).sqrt());
    s.gravity_m_s2 = Vector3::new(0.0, 0.0, -9.81);
    s.fluid_density_kg_m3 = rho_f;
    let mut dem = Dem::new(s)?;
    let w = dem.buoyant_weight_n();
    let ke_tol = t.f64(0, "ke_over_mgr")?;
    let mgr = w * r;
    // at rest: KE below ke_tol m g r after 0.1 s, checked every 1000 steps, within 2 s
    let rest = Rest::Absolute {
        below_j: ke_tol * mgr,
        after_s: 0.1,
    };
    let rule = StopRule::new(1000.0 * dem.dt_s(), 2.0, rest)?;
    if crate::dem::settle(&mut dem, &rule)? != crate::dem::Stop::AtRest {
        return Err(Error::Validation(format!(
            "bed not at rest after {:.3} s: KE = {:e} J",
            dem.time_s,
            dem.kinetic_energy()
        )));
    }
    // time average over a window: the mean of sum m a is the momentum change over the window
    // divided by its length, at most 2 sqrt(2 M KE) / T
    let window = 5000u64;
    let mut sum = 0.0;
    for _ in 0..window {
        dem.step()?;
        sum += dem.floor_force_n;
    }
    let mean = sum / window as f64;
    Ok(vec![Row::new(
        format!("mean floor force over {window} steps / buoyant weight, {n} spheres mu={mu}"),
        mean,
        w,
        w,
    )])
}

register!("709" => case_709);
/// Case 709: the pressure-controlled top wall holds its target once the bed is consolidated:
/// the built-in small scene without gravity, the wall driven to the target pressure of the
/// table; after the scene's stop criterion, the wall pressure averaged over a window equals the
/// target within the band of the table, and the wall no longer moves (its travel over the
/// window below the table's fraction of a diameter) nor shakes (its RMS speed over the window
/// below the table's fraction of its speed limit). Rows' scales are their allowed deviations.
pub fn case_709(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let target = t.f64(0, "target_pressure_Pa")?;
    let band = t.f64(0, "pressure_rel_band")?;
    let travel_tol = t.f64(0, "wall_travel_over_d")?;
    let window = t.f64(0, "window_steps")? as u64;
    let speed_tol = t.f64(0, "wall_speed_rms_over_vmax")?;
    let v_max = 0.05;
    let text = include_str!("../../scene/builtin/dem-small.toml")
        .replace(
            "gravity_m_s2 = 9.81",
            &format!("top_pressure_pa = {target}\ntop_speed_max_m_s = {v_max}"),
        )
        .replace(
            "[run]",
            &format!("[run]\nke_fraction = {}", t.f64(0, "ke_fraction")?),
        );
    let scene = crate::scene::dem::parse_scene(&text, "case 709")?;
    let mut dem = crate::scene::dem::build(&scene)?;
    let stop = crate::dem::settle(&mut dem, &scene.rule)?;
    if stop == crate::dem::Stop::TimeLimit {
        return Err(Error::Validation(format!(
            "the bed did not consolidate: {}",
            stop.reason(&scene.rule)
        )));
    }
    let area = scene.setup.lx_m * scene.setup.ly_m;
    let z0 = dem.top_z_m;
    let (mut sum, mut v2) = (0.0, 0.0);
    for _ in 0..window {
        dem.step()?;
        sum += dem.top_force_n / area;
        v2 += dem.top_v_m_s * dem.top_v_m_s;
    }
    let d = 2.0 * scene.setup.start.radii()[0];
    Ok(vec![
        Row::new(
            format!("mean wall pressure over {window} steps / target {target} Pa"),
            sum / window as f64 / target,
            1.0,
            band,
        ),
        Row::new(
            "wall travel over the window / d",
            (dem.top_z_m - z0) / d,
            0.0,
            travel_tol,
        ),
        Row::new(
            format!("RMS wall speed over the window / speed limit {v_max} m/s"),
            (v2 / window as f64).sqrt() / v_max,
            0.0,
            speed_tol,
        ),
    ])
}

register!("710" => case_710);
/// Case 710: pore size distribution by local thickness (`analysis::pore_size`) of the fixed
/// bed `reference/pore_size_bed.xyz` against PoreSpy's (`reference/pore_size_porespy.csv`,
/// made offline by `reference/scripts/pore_size_porespy.py`): the pore voxel count and the
/// fraction of the pore voxels at every radius must agree exactly (same voxels, same
/// definition; scale 1e-9). Closed forms: a slab of 7 pore layers has one thickness, 4 voxels;
/// the largest inscribed sphere of a simple cubic packing of touching spheres of diameter D
/// is (sqrt 3 - 1) D / 2, found within sqrt(3) h at two resolutions.
pub fn case_710(ctx: &CaseContext) -> Result<Vec<Row>> {
    use crate::analysis::pore_size::{pore_size_distribution, voxelize_bed, VoxelGrid};
    use crate::analysis::rdf::Bed;
    let t = ctx.expected_table()?;
    let text = std::fs::read_to_string(ctx.resolve("reference/pore_size_bed.xyz"))?;
    let (cell, parts) = crate::io::xyz::parse(&text, "reference/pore_size_bed.xyz")?;
    let pos: Vec<Vector3<f64>> = parts.iter().map(|p| p.position).collect();
    let radius: Vec<f64> = parts.iter().map(|p| p.radius).collect();
    let bed = Bed {
        pos: &pos,
        radius: &radius,
        lx_m: cell.lengths[0],
        ly_m: cell.lengths[1],
    };
    let (lo, hi) = pos
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.z), b.max(p.z))
        });
    let grid = voxelize_bed(&bed, lo, hi, bed.mean_diameter() / 8.0)?;
    let h = grid.spacing_m[0];
    let psd = pore_size_distribution(&grid)?;
    let mut rows = Vec::new();
    let pore_voxels = grid.pore.iter().filter(|p| **p).count() as f64;
    let mut ref_voxels = 0.0;
    for i in 0..t.len() {
        let r_ref = t.f64(i, "radius_voxels")?;
        ref_voxels += t.f64(i, "pore_voxels")?;
        // PoreSpy's distances are single precision: radii match to 1e-6
        let got = psd
            .iter()
            .filter(|(r, _)| (r / h - r_ref).abs() <= 1e-6 * r_ref)
            .map(|(_, f)| *f)
            .sum::<f64>();
        rows.push(Row::new(
            format!("fraction of pore voxels at LT = {r_ref:.4} h"),
            got,
            t.f64(i, "pore_volume_fraction")?,
            1e-9,
        ));
    }
    rows.push(Row::new(
        "pore voxels of the grid",
        pore_voxels,
        ref_voxels,
        0.5,
    ));
    // slab: 7 pore layers between solid layers, periodic in x and y
    let n = [6usize, 6, 9];
    let slab: Vec<bool> = (0..n[0] * n[1] * n[2])
        .map(|idx| {
            let k = idx / (n[0] * n[1]);
            (1..=7).contains(&k)
        })
        .collect();
    let g = VoxelGrid::new(n, [1.0; 3], [0.0; 3], [true, true, false], slab)?;
    let s = pore_size_distribution(&g)?;
    rows.push(Row::new(
        "slab of 7 layers: sizes found",
        s.len() as f64,
        1.0,
        0.5,
    ));
    rows.push(Row::new("slab of 7 layers: LT / h", s[0].0, 4.0, 1e-12));
    // simple cubic packing of touching unit spheres, 2 x 2 x 3 sites
    let mut sc = Vec::new();
    for k in 0..3 {
        for j in 0..2 {
            for i in 0..2 {
                sc.push(Vector3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5));
            }
        }
    }
    let sc_r = vec![0.5; sc.len()];
    let sc_bed = Bed {
        pos: &sc,
        radius: &sc_r,
        lx_m: 2.0,
        ly_m: 2.0,
    };
    let want = 0.5 * (3.0f64.sqrt() - 1.0);
    for k in [12.0, 24.0] {
        let g = voxelize_bed(&sc_bed, 0.5, 2.5, 1.0 / k)?;
        let largest = pore_size_distribution(&g)?.last().map_or(f64::NAN, |x| x.0);
        rows.push(Row::new(
            format!("simple cubic: largest inscribed radius / D at h = D/{k}"),
            largest,
            want,
            3.0f64.sqrt() / k,
        ));
    }
    Ok(rows)
}

/// One oblique impact of a sphere (radius r, no spin) on the floor at speed v and angle theta
/// from the normal, no gravity: (normal impulse J_n, tangential impulse J_t, R w after,
/// restitution measured) with J = m |dv|, once the contact has ended; time step t_c / `steps_per_tc`.
fn oblique_impact(
    model: ContactModel,
    r: f64,
    v: f64,
    theta: f64,
    steps_per_tc: f64,
) -> Result<(f64, f64, f64, f64)> {
    let mat = Material::new(1e8, 0.3)?;
    let l = 40.0 * r;
    let (vt, vn) = (v * theta.sin(), v * theta.cos());
    let m = mass(r);
    let pm = PairMaterial::new(&mat, &mat);
    let tc = hertz_constant() * (m * m / (r * pm.e_star_pa * pm.e_star_pa * vn)).powf(0.2);
    let gap = 0.01 * r;
    let mut p = Particles::at_rest(vec![Vector3::new(0.5 * l, 0.5 * l, r + gap)], vec![r], RHO);
    p.vel[0] = Vector3::new(vt, 0.0, -vn);
    let mut s = setup(model, mat, mat, l, l, p, v);
    s.time_step = TimeStep::Given {
        dt_s: tc / steps_per_tc,
    };
    let mut dem = Dem::new(s)?;
    let mut touched = false;
    for _ in 0..(20.0 * (gap / vn + tc) / dem.dt_s()) as u64 {
        dem.step()?;
        let delta = r - dem.p.pos[0].z;
        if delta > 0.0 {
            touched = true;
        } else if touched {
            let u = dem.p.vel[0];
            return Ok((
                m * (u.z + vn),
                m * (vt - u.x),
                r * dem.p.omega[0].y,
                u.z / vn,
            ));
        }
    }
    Err(Error::Validation(
        "oblique impact: the contact did not end".into(),
    ))
}

register!("711", "712" => case_711);
/// Cases 711 (elastic) and 712 (with normal damping): oblique impacts on the floor (Hertz–Mindlin,
/// Coulomb mu). For tan(theta) above (7/2) mu (1 + e) a rigid body slides throughout the contact,
/// so the tangential impulse is mu times the normal one (mu (1 + e) m v_n) and the spin gained
/// is R w = (5/2) J_t / m (torque R F_t, I = (2/5) m R^2). A soft contact with a normal dashpot
/// sticks at its onset: 712 takes the expected J_t / (mu J_n) from the contact's own ODE
/// (reference/oblique_impact_ode.csv, computed without porelab) and checks that the error falls
/// with the time step. Each row's scale is its allowed deviation (table).
pub fn case_711(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let ode = if ctx.id == "712" {
        Some(crate::validation::Table::read(
            ctx.repo_root.join("reference/oblique_impact_ode.csv"),
        )?)
    } else {
        None
    };
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let (mu, e_req, over, damp_ratio) = (
            t.f64(i, "mu")?,
            t.f64(i, "restitution")?,
            t.f64(i, "tan_theta_over_threshold")?,
            t.f64(i, "tangential_damping_ratio")?,
        );
        let (r, v) = (1e-3, 1.0);
        let model = ContactModel::new(
            NormalModel::Hertz,
            DampingModel::restitution(e_req)?,
            TangentialModel::Mindlin { mu, damp_ratio },
        )?;
        // the threshold uses the restitution the contact law gives (measured head-on on the
        // same impact: Hertz restitution damping gives e close to, not exactly, the input)
        let (_, _, _, e) = oblique_impact(model, r, v, 0.0, 200.0)?;
        let theta = (over * 3.5 * mu * (1.0 + e)).atan();
        let (jn, jt, rw, _) = oblique_impact(model, r, v, theta, 200.0)?;
        let m = mass(r);
        let label =
            format!("mu={mu} e={e:.4} eta_t/eta_n={damp_ratio} tan(theta)={over} x threshold");
        let tol = t.f64(i, "impulse_rel_tol")?;
        // the soft contact's own J_t / (mu J_n), or the rigid body's 1
        let want = match &ode {
            Some(o) => {
                let j = (0..o.len())
                    .find(|&j| {
                        [
                            ("mu", mu),
                            ("restitution", e_req),
                            ("tangential_damping_ratio", damp_ratio),
                            ("tan_theta_over_threshold", over),
                        ]
                        .iter()
                        .all(|&(k, x)| o.f64(j, k).is_ok_and(|y| y == x))
                    })
                    .ok_or_else(|| {
                        Error::Validation(format!(
                            "case 712 row {i}: no row of {} for mu {mu}, e {e_req}, eta_t/eta_n \
                             {damp_ratio}, {over} x threshold",
                            o.path().display()
                        ))
                    })?;
                o.f64(j, "jt_over_mu_jn")?
            }
            None => 1.0,
        };
        let source = if ode.is_some() {
            "contact ODE"
        } else {
            "rigid body"
        };
        rows.push(Row::new(
            format!("{label}: J_t / (mu J_n) vs the {source}"),
            jt / (mu * jn),
            want,
            tol,
        ));
        rows.push(Row::new(
            format!("{label}: J_t / (mu (1 + e) m v cos theta) vs the {source}"),
            jt / (mu * (1.0 + e) * m * v * theta.cos()),
            want,
            tol,
        ));
        rows.push(Row::new(
            format!("{label}: R w / (5 J_t / 2 m)"),
            rw / (2.5 * jt / m),
            1.0,
            1e-9,
        ));
        if ode.is_some() && want != 1.0 {
            // the time step's share: at t_c/800 the error to the ODE is at most half that at
            // t_c/200 (first order gives 1/4); the row's value is the ratio of the two errors
            let (jn4, jt4, _, _) = oblique_impact(model, r, v, theta, 800.0)?;
            let fine = (jt4 / (mu * jn4) - want).abs();
            let coarse = (jt / (mu * jn) - want).abs();
            rows.push(Row::new(
                format!("{label}: error at t_c/800 over error at t_c/200 (at most 1/2)"),
                fine / coarse,
                0.25,
                0.25,
            ));
        }
    }
    Ok(rows)
}
