//! Cases 713-714: the contact law of Zhou, Xu, Yu & Zulli (Powder Technol. 125, 45, 2002), the
//! model of seed 002's Table 1, against what it implies in closed form: the undamped Hertz
//! contact time, elastic rebound without damping, restitution falling with c_n (and, with
//! the dashpot ~ delta^(1/4), independent of the impact speed; values against an RK4 of the
//! contact ODE written in the runner), the tangential spring's curve and its full mobilisation
//! at xi_max, and its initial stiffness equal to Mindlin's 8 G* sqrt(R* delta).

use super::dem::{hertz_constant, impact, mass, pair_impact_at_phase, restitution_rk4};
use crate::dem::model::{zhou_slip_displacement, ContactState};
use crate::dem::{
    ContactModel, DampingModel, Material, NormalModel, PairMaterial, TangentialModel,
};
use crate::validation::{CaseContext, Row};
use crate::{Error, Result};
use nalgebra::Vector3;

/// The law of Zhou et al. (2002) with damping c_n (none at 0), friction mu and no tangential
/// dashpot.
fn zhou(c_n: f64, mu: f64) -> Result<ContactModel> {
    ContactModel::new(
        NormalModel::Hertz,
        DampingModel::zhou(c_n)?,
        TangentialModel::zhou(mu, 0.0)?,
    )
}

/// Tangential force magnitude of a static contact (overlap `delta`, normal z) after the spring
/// has been stretched to `x` xi_max along x in `steps` equal steps (v_t = 0 at the full step, so
/// no dashpot), and the elastic normal force.
fn stretched(
    mu: f64,
    delta: f64,
    r_eff: f64,
    pm: &PairMaterial,
    x: f64,
    steps: usize,
) -> Result<(f64, f64)> {
    let model = zhou(0.0, mu)?;
    let xi_max = zhou_slip_displacement(mu, delta, pm);
    let dt = 1e-6;
    let u = x * xi_max / (steps as f64 * dt);
    let mut xi = Vector3::zeros();
    let mut f = Vector3::zeros();
    for _ in 0..steps {
        let c = ContactState {
            delta,
            n: Vector3::z(),
            v_half: Vector3::new(u, 0.0, 0.0),
            v_full: Vector3::zeros(),
            r_eff,
            m_eff: 1e-6,
            dt,
        };
        f = model.force(&c, pm, &mut xi).0;
    }
    Ok((-f.x, f.z))
}

register!("713", "714" => case_713_714);
/// Cases 713 and 714 (rows per expected.csv `check`):
/// * `tc`: head-on impact of two equal spheres, c_n = 0: contact time against
///   c (m*^2/(R* E*^2 v))^(1/5), c = 2.868 (exact constant in [`hertz_constant`]);
/// * `e`: restitution against the RK4 of m* x'' = -(4/3) E* sqrt(R*) x^(3/2) - c_n sqrt(6 m* S_n) x'
///   (at most 0 without tension; 1 exactly at c_n = 0, within `tol`); with damping the row is e
///   at dt/4 within a third of its change from dt (the engine converges to the ODE at order
///   >= 1; the dashpot ~ delta^(1/4) is not smooth at the onset, so not as dt^2);
/// * `speed`: e(v) / e(v_ref) = 1, every impact starting at the same step phase (the ODE is
///   self-similar in v, so the discrete problems are the same in reduced units);
/// * `monotone`: the number of strict falls of e along the rows' increasing c_n;
/// * `spring`: |F_t| / (mu F_cn) against 1 - (1 - min(x, 1))^(3/2) at |xi| = x xi_max;
/// * `stiffness`: the secant stiffness at x = 1e-9 against 8 G* sqrt(R* delta).
pub fn case_713_714(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    let mut falls: Vec<(f64, f64)> = Vec::new();
    let mut speed_ref: Option<f64> = None;
    for i in 0..t.len() {
        let check = t.str(i, "check")?;
        let mat = Material::new(t.f64(i, "young_Pa")?, t.f64(i, "poisson")?)?;
        let pm = PairMaterial::new(&mat, &mat);
        let (r, c_n, mu) = (t.f64(i, "radius_m")?, t.f64(i, "c_n")?, t.f64(i, "mu")?);
        let (m_eff, r_eff) = (0.5 * mass(r), 0.5 * r);
        let tol = t.f64(i, "tol")?;
        match check {
            "tc" | "e" | "speed" | "monotone" => {
                let v = t.f64(i, "speed_m_s")?;
                let frac = t.f64(i, "dt_over_tc")?;
                let tc = hertz_constant()
                    * (m_eff * m_eff / (r_eff * pm.e_star_pa * pm.e_star_pa * v)).powf(0.2);
                let model = zhou(c_n, mu)?;
                // speed rows: every impact starts at the same step phase (below)
                let (e, tc_got) = if check == "speed" {
                    pair_impact_at_phase(model, mat, r, v, frac * tc, 0.5)?
                } else {
                    impact(model, mat, mat, r, v, frac * tc, false)?
                };
                let label = format!("c_n={c_n} v={v} dt=tc*{frac}");
                match check {
                    "tc" => rows.push(Row::new(
                        format!("{label}: contact time (s)"),
                        tc_got,
                        tc,
                        tol * tc,
                    )),
                    "e" if c_n > 0.0 => {
                        // convergence to the ODE: at dt/4 the error must be at most a third
                        // of the change from dt (error ~ dt^p with p >= 1)
                        let e_rk = restitution_rk4(&model, &pm, r_eff, m_eff, v, tc, 200_000);
                        let (e4, _) = impact(model, mat, mat, r, v, 0.25 * frac * tc, false)?;
                        rows.push(Row::new(
                            format!(
                                "{label}/4: e vs RK4 (at dt {:+.2e}, at dt/4 {:+.2e} relative)",
                                e / e_rk - 1.0,
                                e4 / e_rk - 1.0
                            ),
                            e4,
                            e_rk,
                            (e - e4).abs() / 3.0,
                        ));
                    }
                    "e" => rows.push(Row::new(format!("{label}: e vs RK4"), e, 1.0, tol)),
                    "speed" => match speed_ref {
                        None => speed_ref = Some(e),
                        Some(e0) => rows.push(Row::new(
                            format!("{label}: e(v)/e(v_ref)"),
                            e / e0,
                            1.0,
                            tol,
                        )),
                    },
                    _ => falls.push((c_n, e)),
                }
            }
            "spring" | "stiffness" => {
                let delta = t.f64(i, "delta_m")?;
                let x = t.f64(i, "x_over_xmax")?;
                let (ft, fn_) = stretched(mu, delta, r_eff, &pm, x, 16)?;
                if check == "spring" {
                    let xc = x.min(1.0);
                    rows.push(Row::new(
                        format!("mu={mu} nu={} x={x}: |F_t|/(mu F_cn)", mat.poisson),
                        ft / (mu * fn_),
                        1.0 - (1.0 - xc).powf(1.5),
                        tol,
                    ));
                } else {
                    let k = ft / (x * zhou_slip_displacement(mu, delta, &pm));
                    let mindlin = 8.0 * pm.g_star_pa * (r_eff * delta).sqrt();
                    rows.push(Row::new(
                        format!("mu={mu} nu={}: initial k_t vs Mindlin (N/m)", mat.poisson),
                        k,
                        mindlin,
                        tol * mindlin,
                    ));
                }
            }
            other => {
                return Err(Error::Validation(format!(
                    "case {}: unknown check `{other}` (line {})",
                    ctx.id,
                    t.line(i)
                )))
            }
        }
    }
    if falls.len() >= 2 {
        falls.sort_by(|a, b| a.0.total_cmp(&b.0));
        let n_falls = falls.windows(2).filter(|w| w[1].1 < w[0].1).count();
        let listing: Vec<String> = falls.iter().map(|(c, e)| format!("{c}:{e:.4}")).collect();
        rows.push(Row::new(
            format!("strict falls of e with c_n (c_n:e {})", listing.join(" ")),
            n_falls as f64,
            (falls.len() - 1) as f64,
            0.5,
        ));
    }
    Ok(rows)
}
