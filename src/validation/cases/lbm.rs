//! Cases 801-806: the lattice-Boltzmann engine against closed forms (plane Poiseuille,
//! Guo & Zhao's Brinkman channel, Taylor-Green decay, nu(tau) of seed 002 eq. 8) and the
//! literature table of Zick & Homsy (1982) for simple cubic sphere arrays.

use super::common::non_empty;
use crate::lbm::choice::{dispatch, CollisionKind, Job, LatticeKind};
use crate::lbm::flows::{
    brinkman_poiseuille, channel_coordinate, drag_coefficient, poiseuille, sangani_acrivos_sc,
    sphere_array_mask,
};
use crate::lbm::geometry::{Dims, Geometry};
use crate::lbm::problems::{permeability, taylor_green_viscosity, Channel};
use crate::lbm::steady::SteadyControl;
use crate::lbm::{Collision, Lattice};
use crate::validation::{CaseContext, Row, Table};
use crate::{Error, Result};

fn kinds(t: &Table, i: usize) -> Result<(LatticeKind, CollisionKind)> {
    Ok((
        LatticeKind::parse(t.str(i, "lattice")?, "lattice")?,
        CollisionKind::parse(t.str(i, "collision")?, "collision")?,
    ))
}

/// Steady to a relative change of the mean velocity below 1e-13 per 500 steps (exactness
/// checks: the transient left is then below ~1e-11 of the flow).
const TIGHT: SteadyControl = SteadyControl {
    check_every: 500,
    tol: 1e-13,
    max_steps: 2_000_000,
};

/// Steady to 1e-11 per 1000 steps (convergence-order checks; round-off makes the mean
/// velocity of a slow porous flow wander by ~1e-11 relative, so 1e-13 is out of reach there).
const STEADY: SteadyControl = SteadyControl {
    check_every: 1000,
    tol: 1e-11,
    max_steps: 2_000_000,
};

/// Relative L2 error of a steady channel profile against `exact(y)` (y from the lower wall).
struct ChannelError {
    channel: Channel,
    ctl: SteadyControl,
    exact: Box<dyn Fn(f64) -> f64>,
}

impl Job for ChannelError {
    type Out = Result<f64>;
    fn run<L: Lattice, C: Collision>(self, coll: C) -> Result<f64> {
        let (prof, st) = self.channel.steady::<L, C>(coll, self.ctl)?;
        if !st.converged {
            return Err(Error::Validation(format!(
                "channel h = {} not steady after {} steps (residual {:e})",
                self.channel.h, st.steps, st.residual
            )));
        }
        let (mut e2, mut n2) = (0.0, 0.0);
        for (i, got) in prof.iter().enumerate() {
            let want = (self.exact)(channel_coordinate(i + 1));
            e2 += (got - want).powi(2);
            n2 += want * want;
        }
        Ok((e2 / n2).sqrt())
    }
}

/// Runs `f(table, row, lattice, collision, tau)` for every row of the case's expected.csv and
/// collects the rows it returns.
fn per_row(
    ctx: &CaseContext,
    mut f: impl FnMut(&Table, usize, LatticeKind, CollisionKind, f64) -> Result<Option<Row>>,
) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    non_empty(&t)?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let (lat, coll) = kinds(&t, i)?;
        if let Some(r) = f(&t, i, lat, coll, t.f64(i, "tau")?)? {
            rows.push(r);
        }
    }
    Ok(rows)
}

fn nu_of(tau: f64) -> f64 {
    (tau - 0.5) / 3.0
}

fn plain_channel_error(
    lat: LatticeKind,
    coll: CollisionKind,
    tau: f64,
    h: usize,
    g: f64,
    ctl: SteadyControl,
) -> Result<f64> {
    let nu = nu_of(tau);
    let hf = h as f64;
    channel_error(
        lat,
        coll,
        tau,
        (h, g, None),
        ctl,
        Box::new(move |y| poiseuille(y, hf, g, nu)),
    )
}

/// The relative L2 error of the steady channel (h, g, porous medium) against `exact`.
fn channel_error(
    lat: LatticeKind,
    coll: CollisionKind,
    tau: f64,
    (h, g, porous): (usize, f64, Option<(f64, f64, bool)>),
    ctl: SteadyControl,
    exact: Box<dyn Fn(f64) -> f64>,
) -> Result<f64> {
    let channel = Channel {
        h,
        g,
        wall_u: 0.0,
        porous,
    };
    dispatch(
        lat,
        coll,
        tau,
        ChannelError {
            channel,
            ctl,
            exact,
        },
    )
}

/// Case 801: BGK plane Poiseuille, order of the L2 error between H and 2H (expected 2).
pub fn case_801(ctx: &CaseContext) -> Result<Vec<Row>> {
    per_row(ctx, |t, i, lat, coll, tau| {
        let h = t.f64(i, "h_coarse")? as usize;
        let g = t.f64(i, "g_lattice")?;
        let e1 = plain_channel_error(lat, coll, tau, h, g, STEADY)?;
        let e2 = plain_channel_error(lat, coll, tau, 2 * h, g, STEADY)?;
        let order = (e1 / e2).log2();
        eprintln!(
            "801 {} {} tau={tau} H={h}: L2 {e1:.3e} -> {e2:.3e}, order {order:.4}",
            lat.name(),
            coll.name()
        );
        Ok(Some(Row::new(
            format!("{} {} tau={tau} H={h}->{}", lat.name(), coll.name(), 2 * h),
            order,
            t.f64(i, "expected_order")?,
            1.0,
        )))
    })
}

/// Case 802: TRT (Lambda = 3/16) plane Poiseuille is exact: relative L2 error 0.
pub fn case_802(ctx: &CaseContext) -> Result<Vec<Row>> {
    per_row(ctx, |t, i, lat, coll, tau| {
        let h = t.f64(i, "h")? as usize;
        let e = plain_channel_error(lat, coll, tau, h, t.f64(i, "g_lattice")?, TIGHT)?;
        eprintln!(
            "802 {} {} tau={tau} H={h}: L2 {e:.3e}",
            lat.name(),
            coll.name()
        );
        Ok(Some(Row::new(
            format!("{} {} tau={tau} H={h}", lat.name(), coll.name()),
            e,
            t.f64(i, "expected_rel_l2")?,
            1.0,
        )))
    })
}

/// Cells across the Brinkman wall layer sqrt(K/eps) that case 803 requires at its coarse grid.
const MIN_LAYER_CELLS: f64 = 4.0;

/// Case 803: Guo-Zhao porous Poiseuille against the Brinkman solution; order between H, 2H.
pub fn case_803(ctx: &CaseContext) -> Result<Vec<Row>> {
    per_row(ctx, |t, i, lat, coll, tau| {
        let eps = t.f64(i, "eps")?;
        let da = t.f64(i, "darcy")?;
        let h = t.f64(i, "h_coarse")? as usize;
        let g_scale = t.f64(i, "g_lattice")?;
        // the asymptotic range needs the wall layer sqrt(K/eps) = H sqrt(Da/eps) resolved
        let layer = h as f64 * (da / eps).sqrt();
        if layer < MIN_LAYER_CELLS {
            return Err(Error::Validation(format!(
                "{} line {}: H = {h} resolves the Brinkman layer H sqrt(Da/eps) by {layer:.2} \
                 cells, fewer than {MIN_LAYER_CELLS}: raise h_coarse",
                t.path().display(),
                t.line(i)
            )));
        }
        let err = |h: usize| -> Result<f64> {
            let hf = h as f64;
            let k = da * hf * hf;
            let nu = nu_of(tau);
            // same peak velocity (~ g K / nu) at every resolution
            let g = g_scale * nu / k;
            let exact = Box::new(move |y| brinkman_poiseuille(y, hf, g, nu, eps, k));
            channel_error(lat, coll, tau, (h, g, Some((eps, k, false))), STEADY, exact)
        };
        let (e1, e2) = (err(h)?, err(2 * h)?);
        let order = (e1 / e2).log2();
        eprintln!(
            "803 {} {} eps={eps} Da={da:e} H={h}: L2 {e1:.3e} -> {e2:.3e}, order {order:.4}",
            lat.name(),
            coll.name()
        );
        Ok(Some(Row::new(
            format!(
                "{} {} eps={eps} Da={da:e} H={h}->{}",
                lat.name(),
                coll.name(),
                2 * h
            ),
            order,
            t.f64(i, "expected_order")?,
            1.0,
        )))
    })
}

struct TaylorGreen {
    n: usize,
    u0: f64,
    t1: u64,
    t2: u64,
}

impl Job for TaylorGreen {
    type Out = Result<f64>;
    fn run<L: Lattice, C: Collision>(self, coll: C) -> Result<f64> {
        taylor_green_viscosity::<L, C>(coll, self.n, self.u0, self.t1, self.t2)
    }
}

/// Case 804: Taylor-Green decay; the recovered viscosity against nu = (tau - 1/2)/3.
pub fn case_804(ctx: &CaseContext) -> Result<Vec<Row>> {
    per_row(ctx, |t, i, lat, coll, tau| {
        let n = t.f64(i, "n")? as usize;
        let nu = nu_of(tau);
        // t1 = one tenth, t2 = one e-fold of the energy decay time 1/(4 nu k^2)
        let k = 2.0 * std::f64::consts::PI / n as f64;
        let td = 1.0 / (4.0 * nu * k * k);
        let (t1, t2) = ((0.1 * td).ceil() as u64, (1.1 * td).ceil() as u64);
        let got = dispatch(
            lat,
            coll,
            tau,
            TaylorGreen {
                n,
                u0: t.f64(i, "u0")?,
                t1,
                t2,
            },
        )?;
        let want = t.f64(i, "expected_nu")?;
        eprintln!(
            "804 {} {} tau={tau} n={n}: nu {got:.6e} vs {want:.6e} ({:.2e})",
            lat.name(),
            coll.name(),
            got / want - 1.0
        );
        Ok(Some(Row::new(
            format!("{} {} tau={tau} n={n}", lat.name(), coll.name()),
            got,
            want,
            want,
        )))
    })
}

struct SphereArray {
    n: usize,
    radius: f64,
    g: f64,
    ctl: SteadyControl,
}

impl Job for SphereArray {
    type Out = Result<(f64, f64, f64)>;
    /// (k in cells^2, solid fraction of the voxels, Re = <u> 2a / nu)
    fn run<L: Lattice, C: Collision>(self, coll: C) -> Self::Out {
        let d = Dims::new(self.n, self.n, self.n)?;
        let geom = Geometry::new::<L>(d, sphere_array_mask(self.n, self.radius), |_| [0.0; 3])?;
        let p = permeability::<L, C>(geom, coll, self.g, self.ctl, |_, _| {})?;
        if !p.converged {
            return Err(Error::Validation(format!(
                "sphere array n = {} not steady after {} steps (residual {:e})",
                self.n, p.steps, p.residual
            )));
        }
        let nu = (1.0 / coll.omega_plus() - 0.5) / 3.0;
        Ok((p.k, 1.0 - p.porosity, p.mean_u * 2.0 * self.radius / nu))
    }
}

/// Sphere arrays: steady to 1e-7 per 100 steps (the slowest mode decays over ~L^2/(4 pi^2 nu)
/// ~ 200 steps at n = 32, so the transient left is ~1e-6 of k).
const ARRAY_CTL: SteadyControl = SteadyControl {
    check_every: 100,
    tol: 1e-7,
    max_steps: 200_000,
};

/// k of the simple cubic array of solid fraction phi on an n^3 lattice; `g16` is the force at
/// n = 16, scaled as (16/n)^3 so that Re (~ g n^3 / nu^2) is the same at every resolution.
fn sphere_array_k(
    lat: LatticeKind,
    coll: CollisionKind,
    tau: f64,
    n: usize,
    phi: f64,
    g16: f64,
) -> Result<(f64, f64, f64)> {
    let radius = n as f64 * (3.0 * phi / (4.0 * std::f64::consts::PI)).cbrt();
    let g = g16 * (16.0 / n as f64).powi(3);
    dispatch(
        lat,
        coll,
        tau,
        SphereArray {
            n,
            radius,
            g,
            ctl: ARRAY_CTL,
        },
    )
}

/// Case 808: Darcy's law. Rows "force": k at force g against k at g_ref (ratio 1, low Re);
/// rows "viscosity": TRT k at tau against k at tau_ref (ratio 1). BGK's ratio is printed.
pub fn case_808(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    non_empty(&t)?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let (lat, coll) = kinds(&t, i)?;
        let phi = t.f64(i, "phi")?;
        let n = t.f64(i, "n")? as usize;
        let (tau_ref, tau) = (t.f64(i, "tau_ref")?, t.f64(i, "tau")?);
        let (g_ref, g) = (t.f64(i, "g_ref")?, t.f64(i, "g")?);
        let (k_ref, _, re_ref) = sphere_array_k(lat, coll, tau_ref, n, phi, g_ref)?;
        let (k, _, re) = sphere_array_k(lat, coll, tau, n, phi, g)?;
        let label = format!(
            "{} {} {} phi={phi} n={n} tau {tau_ref}->{tau} g {g_ref:e}->{g:e}",
            t.str(i, "kind")?,
            lat.name(),
            coll.name()
        );
        eprintln!(
            "808 {label}: k {k_ref:.6e} -> {k:.6e} ratio {:.6} (Re {re_ref:.2e}, {re:.2e})",
            k / k_ref
        );
        if t.str(i, "kind")? == "report" {
            continue;
        }
        rows.push(Row::new(label, k / k_ref, t.f64(i, "expected_ratio")?, 1.0));
    }
    Ok(rows)
}

/// Cases 806 (slow, the whole table) and 807 (fast, one row): simple cubic sphere arrays, drag coefficient K = 2a^2/(9 phi k) against Zick &
/// Homsy (1982) Table 2; the error must fall from the coarse to the fine resolution.
pub fn case_806_807(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    non_empty(&t)?;
    let mut rows = Vec::new();
    let mut problems = Vec::new();
    let mut sq = [0.0; 2];
    for i in 0..t.len() {
        let (lat, coll) = kinds(&t, i)?;
        let tau = t.f64(i, "tau")?;
        let phi = t.f64(i, "phi")?;
        let want = t.f64(i, "K_zick_homsy")?;
        if phi <= 0.125 {
            // the table against the dilute series (an input check, not the code under test)
            let sa = sangani_acrivos_sc(phi);
            if (sa / want - 1.0).abs() > 2e-3 {
                problems.push(format!(
                    "table K({phi}) = {want} differs from Sangani-Acrivos {sa:.4}"
                ));
            }
        }
        let mut errs = Vec::new();
        for col in ["n_coarse", "n_fine"] {
            if t.f64(i, col)?.is_nan() {
                return Err(Error::Validation(format!(
                    "{}: {col} missing",
                    t.path().display()
                )));
            }
            let n = t.f64(i, col)? as usize;
            let radius = n as f64 * (3.0 * phi / (4.0 * std::f64::consts::PI)).cbrt();
            let (k, _, re) = sphere_array_k(lat, coll, tau, n, phi, t.f64(i, "g16_lattice")?)?;
            // K from the nominal radius and solid fraction (the staircase is the error measured)
            let kd = drag_coefficient(k, radius, phi);
            eprintln!(
                "806 {} {} phi={phi} n={n}: K {kd:.4} vs {want} ({:+.2}%), Re {re:.2e}",
                lat.name(),
                coll.name(),
                100.0 * (kd / want - 1.0)
            );
            errs.push((kd / want - 1.0).abs());
            if col == "n_fine" {
                rows.push(Row::new(
                    format!("{} {} phi={phi} n={n}", lat.name(), coll.name()),
                    kd,
                    want,
                    want,
                ));
            }
        }
        sq[0] += errs[0] * errs[0];
        sq[1] += errs[1] * errs[1];
    }
    // the staircase error of one sphere is not monotone in n; its RMS over the table must fall
    let rms = |s: f64| (s / t.len() as f64).sqrt();
    eprintln!(
        "{}: RMS relative error {:.3e} (coarse) -> {:.3e} (fine)",
        ctx.id,
        rms(sq[0]),
        rms(sq[1])
    );
    if sq[1] >= sq[0] {
        problems.push(format!(
            "the RMS error over the table did not fall with resolution ({:.2e} -> {:.2e})",
            rms(sq[0]),
            rms(sq[1])
        ));
    }
    if !problems.is_empty() {
        return Err(Error::Validation(problems.join("; ")));
    }
    Ok(rows)
}
