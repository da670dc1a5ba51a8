//! Cases 805 and 809-810: flows through boundaries built by non-equilibrium extrapolation
//! (Guo, Zheng & Shi 2002) and the square duct, against closed forms, with measured
//! convergence orders.

use super::common::non_empty;
use super::lbm::scheme;
use crate::driver::NoHooks;
use crate::lbm::flows::{channel_coordinate, duct_series, poiseuille};
use crate::lbm::problems::{square_duct, ChannelFlow, DrivenChannel, Inlet, NodeCouette};
use crate::lbm::{CollisionModel, LatticeKind, Steady, SteadyControl};
use crate::validation::{CaseContext, Row, Table};
use crate::{Error, Result};

/// Steady to a relative change of the mean velocity below 1e-11 per 1000 steps.
const STEADY: SteadyControl = SteadyControl {
    check_every: 1000,
    tol: 1e-11,
    max_steps: 2_000_000,
};

/// Relative L2 norm of got - want over paired samples.
pub(super) fn rel_l2(pairs: impl Iterator<Item = (f64, f64)>) -> f64 {
    let (mut e2, mut n2) = (0.0, 0.0);
    for (got, want) in pairs {
        e2 += (got - want).powi(2);
        n2 += want * want;
    }
    (e2 / n2).sqrt()
}

/// Refuses a run that did not reach the steady state.
fn require_steady(what: &str, st: &Steady) -> Result<()> {
    if st.converged {
        return Ok(());
    }
    Err(Error::Validation(format!(
        "{what} not steady after {} steps (residual {:e})",
        st.steps, st.residual
    )))
}

/// The row of a measured order log2(e1 / e2) between two grids, printed with its errors.
fn order_row(id: &str, label: String, (e1, e2): (f64, f64), expected: f64) -> Row {
    let order = (e1 / e2).log2();
    eprintln!("{id} {label}: L2 {e1:.3e} -> {e2:.3e}, order {order:.4}");
    Row::new(label, order, expected, 1.0)
}

/// The relative L2 error of the x-velocity profile across the mid-length section of a driven
/// channel against the parabola of peak `u_max`.
fn driven_error(
    (lat, coll): (LatticeKind, CollisionModel),
    ch: DrivenChannel,
    u_max: f64,
) -> Result<f64> {
    let st = ch.steady(lat, coll, STEADY, &mut NoHooks)?;
    require_steady("driven channel", &st)?;
    let d = ch.dims()?;
    let (h, x) = (ch.h, ch.length / 2);
    let hf = h as f64;
    Ok(rel_l2((1..=h).map(|y| {
        let yc = channel_coordinate(y);
        (
            st.fields.u[d.cell(x, y, 0)][0],
            4.0 * u_max * yc * (hf - yc) / (hf * hf),
        )
    })))
}

register!("805" => case_805);
/// Case 805: plane Poiseuille flow driven through non-equilibrium-extrapolation planes, by a
/// density (pressure) difference or by a parabolic velocity inlet; the L2 error of the
/// mid-length profile and its order between H and 2H under diffusive scaling.
pub fn case_805(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let (lat, coll) = scheme(&t, i)?;
        let tau = coll.tau.get();
        let nu = coll.tau.nu();
        let inlet = t.str(i, "inlet")?.to_string();
        let h0 = t.f64(i, "h_coarse")? as usize;
        let err = |h: usize| -> Result<f64> {
            // peak velocity u8 at H = 8, scaled as 8/H (diffusive scaling, Ma ~ 1/H)
            let u_max = t.f64(i, "u_max_h8")? * 8.0 / h as f64;
            let length = 2 * h;
            let g = poiseuille(0.5 * h as f64, h as f64, 1.0, nu).recip() * u_max;
            // pressure gradient c_s^2 (rho_in - rho_out) / L = g (mean density 1)
            let drho = 3.0 * g * length as f64;
            let inlet = match inlet.as_str() {
                "density" => (Inlet::Density(1.0 + 0.5 * drho), 1.0 - 0.5 * drho),
                "velocity" => (Inlet::Parabola(u_max), 1.0),
                other => {
                    return Err(Error::Validation(format!(
                        "{} line {}: inlet = \"{other}\": must be \"density\" or \"velocity\"",
                        t.path().display(),
                        t.line(i)
                    )))
                }
            };
            let ch = DrivenChannel {
                h,
                length,
                inlet: inlet.0,
                rho_out: inlet.1,
            };
            driven_error((lat, coll), ch, u_max)
        };
        let errs = (err(h0)?, err(2 * h0)?);
        let label = format!(
            "{inlet} {} {} tau={tau} H={h0}->{}",
            lat.name(),
            coll.name(),
            2 * h0
        );
        rows.push(order_row("805", label, errs, t.f64(i, "expected_order")?));
    }
    Ok(rows)
}

/// The relative L2 error of the square duct of h x h cells under body force g against the
/// series solution.
fn duct_error((lat, coll): (LatticeKind, CollisionModel), h: usize, g: f64) -> Result<f64> {
    let nu = coll.kernel_nu();
    let (u, st) = square_duct(lat, coll, (h, g), STEADY)?;
    require_steady("square duct", &st)?;
    let a = 0.5 * h as f64;
    Ok(rel_l2(u.iter().enumerate().map(|(k, &got)| {
        let (y, z) = (k % h + 1, k / h + 1);
        let want = duct_series(
            channel_coordinate(y) - a,
            channel_coordinate(z) - a,
            a,
            a,
            g,
            nu,
        );
        (got, want)
    })))
}

register!("810" => case_810);
/// Case 810: square duct under a body force against the series solution; order of the L2
/// error between H and 2H.
pub fn case_810(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let (lat, coll) = scheme(&t, i)?;
        let tau = coll.tau.get();
        let h0 = t.f64(i, "h_coarse")? as usize;
        let g = t.f64(i, "g_lattice")?;
        let errs = (
            duct_error((lat, coll), h0, g)?,
            duct_error((lat, coll), 2 * h0, g)?,
        );
        let label = format!(
            "{} {} tau={tau} H={h0}->{}",
            lat.name(),
            coll.name(),
            2 * h0
        );
        rows.push(order_row("810", label, errs, t.f64(i, "expected_order")?));
    }
    Ok(rows)
}

/// u / U0 at the nodes y = 0..=h of the porous Couette flow (eps, Re, Da) on h cells.
fn couette_profile(
    (lat, coll): (LatticeKind, CollisionModel),
    h: usize,
    (eps, re, da): (f64, f64, f64),
) -> Result<Vec<f64>> {
    let nu = coll.kernel_nu();
    let hf = h as f64;
    let u_wall = re * nu / hf;
    let k = da * hf * hf;
    let couette = NodeCouette {
        h,
        u_wall,
        porous: (eps, k, true),
    };
    let (u, st) = couette.steady(lat, coll, STEADY, &mut NoHooks)?;
    require_steady("porous Couette", &st)?;
    Ok(u.iter().map(|v| v / u_wall).collect())
}

/// The finite-difference profile (eps, Re, Da) of reference/porous_couette.csv: u/U0 at
/// y/H = j/128, refusing rows whose oracle error estimate exceeds 1e-9.
fn couette_reference(ref_table: &Table, eps: f64, re: f64, da: f64) -> Result<Vec<f64>> {
    let mut prof = Vec::new();
    for r in 0..ref_table.len() {
        let same = |col: &str, v: f64| -> Result<bool> {
            Ok((ref_table.f64(r, col)? - v).abs() <= 1e-12 * v.abs())
        };
        if same("eps", eps)? && same("Re", re)? && same("Da", da)? {
            if ref_table.f64(r, "est_abs_err")?.is_nan() || ref_table.f64(r, "est_abs_err")? > 1e-9
            {
                return Err(Error::Validation(format!(
                    "{} line {}: oracle error estimate above 1e-9 (regenerate with `porelab \
                     reference regen porous-couette`)",
                    ref_table.path().display(),
                    ref_table.line(r)
                )));
            }
            prof.push(ref_table.f64(r, "u_over_U0")?);
        }
    }
    if prof.len() != 129 {
        return Err(Error::Validation(format!(
            "{}: {} points for eps = {eps}, Re = {re}, Da = {da:e}; 129 expected",
            ref_table.path().display(),
            prof.len()
        )));
    }
    Ok(prof)
}

register!("809" => case_809);
/// Case 809: porous plane Couette flow (seed 002 Fig. 6a) against the finite-difference
/// oracle; relative L2 error of the interior nodes, expected 0.
pub fn case_809(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let oracle = Table::read(ctx.repo_root.join("reference/porous_couette.csv"))?;
    non_empty(&oracle)?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let (lat, coll) = scheme(&t, i)?;
        let tau = coll.tau.get();
        let (eps, re, da) = (t.f64(i, "eps")?, t.f64(i, "Re")?, t.f64(i, "Da")?);
        let h = t.f64(i, "h")? as usize;
        if h == 0 || 128 % h != 0 {
            return Err(Error::Validation(format!(
                "{} line {}: h = {h} must divide 128 (the oracle's points)",
                t.path().display(),
                t.line(i)
            )));
        }
        let want = couette_reference(&oracle, eps, re, da)?;
        let got = couette_profile((lat, coll), h, (eps, re, da))?;
        let e = rel_l2((1..h).map(|y| (got[y], want[y * 128 / h])));
        let label = format!(
            "{} {} tau={tau} eps={eps} Re={re} Da={da:e} H={h}",
            lat.name(),
            coll.name()
        );
        eprintln!("809 {label}: relative L2 {e:.3e}");
        rows.push(Row::new(label, e, t.f64(i, "expected_rel_l2")?, 1.0));
    }
    Ok(rows)
}
