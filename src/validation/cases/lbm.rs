//! Cases 801-806: the lattice-Boltzmann engine against closed forms (plane Poiseuille,
//! Guo & Zhao's Brinkman channel, Taylor-Green decay, nu(tau) of seed 002 eq. 8) and the
//! literature table of Zick & Homsy (1982) for simple cubic sphere arrays.

use crate::driver::NoHooks;
use crate::lbm::flows::{
    brinkman_poiseuille, channel_coordinate, cylinder_array_mask, drag_coefficient,
    drummond_tahir_square_drag, poiseuille, sangani_acrivos_sc, sphere_array_mask,
};
use crate::lbm::problems::{permeability, taylor_green_viscosity, Channel, ChannelFlow};
use crate::lbm::{CollisionKind, CollisionModel, Dims, Domain, LatticeKind, SteadyControl, Tau};
use crate::validation::{CaseContext, Row, Table};
use crate::{Error, Result};

/// The lattice and the collision of row `i` (columns `lattice`, `collision`).
pub(super) fn kinds(t: &Table, i: usize) -> Result<(LatticeKind, CollisionKind)> {
    Ok((
        LatticeKind::parse(t.str(i, "lattice")?, "lattice")?,
        CollisionKind::parse(t.str(i, "collision")?, "collision")?,
    ))
}

/// The lattice and the collision at the relaxation time of column `tau` of row `i`.
pub(super) fn scheme(t: &Table, i: usize) -> Result<(LatticeKind, CollisionModel)> {
    let (lat, kind) = kinds(t, i)?;
    Ok((lat, CollisionModel::new(kind, Tau::new(t.f64(i, "tau")?)?)))
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

/// Runs `f(table, row, lattice, collision)` for every row of the case's expected.csv and
/// collects the rows it returns.
fn per_row(
    ctx: &CaseContext,
    mut f: impl FnMut(&Table, usize, LatticeKind, CollisionModel) -> Result<Option<Row>>,
) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let (lat, coll) = scheme(&t, i)?;
        if let Some(r) = f(&t, i, lat, coll)? {
            rows.push(r);
        }
    }
    Ok(rows)
}

/// "D3Q19 TRT tau=1": the lattice, the collision and tau of a row's label.
fn label(lat: LatticeKind, coll: CollisionModel) -> String {
    format!("{} {} tau={}", lat.name(), coll.name(), coll.tau.get())
}

fn plain_channel_error(
    lat: LatticeKind,
    coll: CollisionModel,
    h: usize,
    g: f64,
    ctl: SteadyControl,
) -> Result<f64> {
    let nu = coll.tau.nu();
    let hf = h as f64;
    channel_error(lat, coll, (h, g, None), ctl, move |y| {
        poiseuille(y, hf, g, nu)
    })
}

/// The relative L2 error of the steady channel (h, g, porous medium) against `exact(y)` (y
/// from the lower wall); refuses a run that did not reach the steady state.
fn channel_error(
    lat: LatticeKind,
    coll: CollisionModel,
    (h, g, porous): (usize, f64, Option<(f64, f64, bool)>),
    ctl: SteadyControl,
    exact: impl Fn(f64) -> f64,
) -> Result<f64> {
    let channel = Channel {
        h,
        g,
        wall_u: 0.0,
        porous,
    };
    let (prof, st) = channel.steady(lat, coll, ctl, &mut NoHooks)?;
    if !st.converged {
        return Err(Error::Validation(format!(
            "channel h = {h} not steady after {} steps (residual {:e})",
            st.steps, st.residual
        )));
    }
    let (mut e2, mut n2) = (0.0, 0.0);
    for (i, got) in prof.iter().enumerate() {
        let want = exact(channel_coordinate(i + 1));
        e2 += (got - want).powi(2);
        n2 += want * want;
    }
    Ok((e2 / n2).sqrt())
}

register!("801" => case_801);
/// Case 801: BGK plane Poiseuille, order of the L2 error between H and 2H (expected 2).
pub fn case_801(ctx: &CaseContext) -> Result<Vec<Row>> {
    per_row(ctx, |t, i, lat, coll| {
        let h = t.f64(i, "h_coarse")? as usize;
        let g = t.f64(i, "g_lattice")?;
        let e1 = plain_channel_error(lat, coll, h, g, STEADY)?;
        let e2 = plain_channel_error(lat, coll, 2 * h, g, STEADY)?;
        let order = (e1 / e2).log2();
        let name = label(lat, coll);
        eprintln!("801 {name} H={h}: L2 {e1:.3e} -> {e2:.3e}, order {order:.4}");
        Ok(Some(Row::new(
            format!("{name} H={h}->{}", 2 * h),
            order,
            t.f64(i, "expected_order")?,
            1.0,
        )))
    })
}

register!("802" => case_802);
/// Case 802: TRT (Lambda = 3/16) plane Poiseuille is exact: relative L2 error 0.
pub fn case_802(ctx: &CaseContext) -> Result<Vec<Row>> {
    per_row(ctx, |t, i, lat, coll| {
        let h = t.f64(i, "h")? as usize;
        let e = plain_channel_error(lat, coll, h, t.f64(i, "g_lattice")?, TIGHT)?;
        let name = label(lat, coll);
        eprintln!("802 {name} H={h}: L2 {e:.3e}");
        Ok(Some(Row::new(
            format!("{name} H={h}"),
            e,
            t.f64(i, "expected_rel_l2")?,
            1.0,
        )))
    })
}

/// Cells across the Brinkman wall layer sqrt(K/eps) that case 803 requires at its coarse grid.
const MIN_LAYER_CELLS: f64 = 4.0;

register!("803" => case_803);
/// Case 803: Guo-Zhao porous Poiseuille against the Brinkman solution; order between H, 2H.
pub fn case_803(ctx: &CaseContext) -> Result<Vec<Row>> {
    per_row(ctx, |t, i, lat, coll| {
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
            let nu = coll.tau.nu();
            // same peak velocity (~ g K / nu) at every resolution
            let g = g_scale * nu / k;
            let exact = move |y| brinkman_poiseuille(y, hf, g, nu, eps, k);
            channel_error(lat, coll, (h, g, Some((eps, k, false))), STEADY, exact)
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

register!("804" => case_804);
/// Case 804: Taylor-Green decay; the recovered viscosity against nu = (tau - 1/2)/3.
pub fn case_804(ctx: &CaseContext) -> Result<Vec<Row>> {
    per_row(ctx, |t, i, lat, coll| {
        let n = t.f64(i, "n")? as usize;
        let nu = coll.tau.nu();
        // t1 = one tenth, t2 = one e-fold of the energy decay time 1/(4 nu k^2)
        let k = 2.0 * std::f64::consts::PI / n as f64;
        let td = 1.0 / (4.0 * nu * k * k);
        let (t1, t2) = ((0.1 * td).ceil() as u64, (1.1 * td).ceil() as u64);
        let got = taylor_green_viscosity(lat, coll, n, t.f64(i, "u0")?, (t1, t2))?;
        let want = t.f64(i, "expected_nu")?;
        let name = label(lat, coll);
        eprintln!(
            "804 {name} n={n}: nu {got:.6e} vs {want:.6e} ({:.2e})",
            got / want - 1.0
        );
        Ok(Some(Row::new(format!("{name} n={n}"), got, want, want)))
    })
}

/// (k in cells^2, solid fraction of the voxels, Re = <u> diameter / nu) of one periodic
/// array cell, the solid `mask` on `dims`, under body force g along x; `diameter` (cells) is
/// the Reynolds number's length. Refuses a run that did not reach the steady state.
fn array_cell(
    (lat, coll): (LatticeKind, CollisionModel),
    dims: Dims,
    mask: Vec<bool>,
    diameter: f64,
    g: f64,
) -> Result<(f64, f64, f64)> {
    let domain = Domain::with_solid(dims, mask)?;
    let p = permeability(lat, coll, domain, g, ARRAY_CTL, &mut NoHooks)?;
    if !p.converged {
        return Err(Error::Validation(format!(
            "array cell {} x {} x {} not steady after {} steps (residual {:e})",
            dims.nx, dims.ny, dims.nz, p.steps, p.residual
        )));
    }
    Ok((p.k, 1.0 - p.porosity, p.mean_u * diameter / p.nu))
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
    scheme: (LatticeKind, CollisionModel),
    n: usize,
    phi: f64,
    g16: f64,
) -> Result<(f64, f64, f64)> {
    let radius = n as f64 * (3.0 * phi / (4.0 * std::f64::consts::PI)).cbrt();
    let g = g16 * (16.0 / n as f64).powi(3);
    let mask = sphere_array_mask(n, radius);
    array_cell(scheme, Dims::new(n, n, n)?, mask, 2.0 * radius, g)
}

register!("808" => case_808);
/// Case 808: Darcy's law. Rows "force": k at force g against k at g_ref (ratio 1, low Re);
/// rows "viscosity": TRT k at tau against k at tau_ref (ratio 1). BGK's ratio is printed.
pub fn case_808(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let (lat, coll) = kinds(&t, i)?;
        let phi = t.f64(i, "phi")?;
        let n = t.f64(i, "n")? as usize;
        let (tau_ref, tau) = (t.f64(i, "tau_ref")?, t.f64(i, "tau")?);
        let (g_ref, g) = (t.f64(i, "g_ref")?, t.f64(i, "g")?);
        let at = |tau: f64| -> Result<_> { Ok((lat, CollisionModel::new(coll, Tau::new(tau)?))) };
        let (k_ref, _, re_ref) = sphere_array_k(at(tau_ref)?, n, phi, g_ref)?;
        let (k, _, re) = sphere_array_k(at(tau)?, n, phi, g)?;
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

/// One row's inputs in a resolution study.
struct StudyRow {
    lat: LatticeKind,
    coll: CollisionModel,
    phi: f64,
    /// The literature value.
    want: f64,
}

/// A resolution study over the rows of expected.csv: `measure(row, n, table, i)` gives the
/// observable on the n_coarse and the n_fine lattice; the fine value is checked against the
/// literature column `want_col` (plus the rows `extra(row, label, fine)` adds), and the RMS
/// error over the table must fall from coarse to fine. `check(row)` names a problem with the
/// literature input itself (an input check, not the code under test).
fn resolution_study(
    ctx: &CaseContext,
    want_col: &str,
    check: impl Fn(&StudyRow) -> Option<String>,
    mut measure: impl FnMut(&StudyRow, usize, &Table, usize) -> Result<f64>,
    extra: impl Fn(&StudyRow, &str, f64) -> Vec<Row>,
) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    let mut problems = Vec::new();
    let mut sq = [0.0; 2];
    for i in 0..t.len() {
        let (lat, coll) = scheme(&t, i)?;
        let r = StudyRow {
            lat,
            coll,
            phi: t.f64(i, "phi")?,
            want: t.f64(i, want_col)?,
        };
        problems.extend(check(&r));
        for (j, col) in ["n_coarse", "n_fine"].into_iter().enumerate() {
            let n = t.f64(i, col)?;
            if !(n.is_finite() && n >= 8.0) {
                return Err(Error::Validation(format!(
                    "{} line {}: {col} = {n}: must be a whole number >= 8",
                    t.path().display(),
                    t.line(i)
                )));
            }
            let n = n as usize;
            let got = measure(&r, n, &t, i)?;
            sq[j] += (got / r.want - 1.0).powi(2);
            if j == 1 {
                let label = format!("{} {} phi={} n={n}", lat.name(), coll.name(), r.phi);
                rows.extend(extra(&r, &label, got));
                rows.push(Row::new(label, got, r.want, r.want));
            }
        }
    }
    // the staircase error of one particle is not monotone in n; its RMS over the table must fall
    rms_must_fall(&ctx.id, sq, t.len(), problems)?;
    Ok(rows)
}

register!("806", "807" => case_806_807);
/// Cases 806 (slow, the whole table) and 807 (fast, one row): simple cubic sphere arrays, drag
/// coefficient K = 2a^2/(9 phi k) against Zick & Homsy (1982) Table 2; the error must fall from
/// the coarse to the fine resolution.
pub fn case_806_807(ctx: &CaseContext) -> Result<Vec<Row>> {
    resolution_study(
        ctx,
        "K_zick_homsy",
        |r| {
            // the table against the dilute series
            let sa = sangani_acrivos_sc(r.phi);
            (r.phi <= 0.125 && (sa / r.want - 1.0).abs() > 2e-3).then(|| {
                format!(
                    "table K({}) = {} differs from Sangani-Acrivos {sa:.4}",
                    r.phi, r.want
                )
            })
        },
        |r, n, t, i| {
            let radius = n as f64 * (3.0 * r.phi / (4.0 * std::f64::consts::PI)).cbrt();
            let g16 = t.f64(i, "g16_lattice")?;
            let (k, _, re) = sphere_array_k((r.lat, r.coll), n, r.phi, g16)?;
            // K from the nominal radius and solid fraction (the staircase is the error measured)
            let kd = drag_coefficient(k, radius, r.phi);
            eprintln!(
                "806 {} {} phi={} n={n}: K {kd:.4} vs {} ({:+.2}%), Re {re:.2e}",
                r.lat.name(),
                r.coll.name(),
                r.phi,
                r.want,
                100.0 * (kd / r.want - 1.0)
            );
            Ok(kd)
        },
        |_, _, _| Vec::new(),
    )
}

/// Dimensionless drag per unit length F/(mu U) = L^2 / k of the square array of cylinders of
/// solid fraction phi, period n cells, one cell along the axis (z); `g32` is the force at
/// n = 32, scaled as (32/n)^3 so that Re is the same at every resolution. Returns (F/(mu U),
/// solid fraction of the voxels, Re on the diameter).
fn cylinder_array_drag(
    scheme: (LatticeKind, CollisionModel),
    n: usize,
    phi: f64,
    g32: f64,
) -> Result<(f64, f64, f64)> {
    // phi = pi a^2 / L^2
    let radius = n as f64 * (phi / std::f64::consts::PI).sqrt();
    let mask = cylinder_array_mask(n, 1, radius);
    let g = g32 * (32.0 / n as f64).powi(3);
    let (k, phi_voxels, re) = array_cell(scheme, Dims::new(n, n, 1)?, mask, 2.0 * radius, g)?;
    // a force g per unit mass on the fluid is the mean pressure gradient of Darcy's law, so
    // F = g L^2 per unit length and F/(mu U) = L^2 / k with k = nu <u> / g
    Ok(((n * n) as f64 / k, phi_voxels, re))
}

/// Solid fractions up to which the Drummond & Tahir expansion is compared (it leaves the
/// Sangani & Acrivos table by 4 % at 0.3 and diverges beyond).
const DRUMMOND_TAHIR_MAX_PHI: f64 = 0.2;

register!("818", "819" => case_818_819);
/// Cases 818 (fast) and 819 (slow): transverse flow through the square array of cylinders;
/// F/(mu U) = L^2/k against Sangani & Acrivos (1982) Table 1 and, for phi <= 0.2, Drummond &
/// Tahir (1984). The RMS error over the rows must fall from the coarse to the fine lattice.
pub fn case_818_819(ctx: &CaseContext) -> Result<Vec<Row>> {
    resolution_study(
        ctx,
        "F_sangani_acrivos",
        |r| {
            // the two references against each other (an input check of the reading)
            let dt = drummond_tahir_square_drag(r.phi);
            (r.phi <= DRUMMOND_TAHIR_MAX_PHI && (dt / r.want - 1.0).abs() > 1e-2).then(|| {
                format!(
                    "table F/(mu U)({}) = {} differs from Drummond-Tahir {dt:.3} by more than 1 %",
                    r.phi, r.want
                )
            })
        },
        |r, n, t, i| {
            let g32 = t.f64(i, "g32_lattice")?;
            let (f, phi_vox, re) = cylinder_array_drag((r.lat, r.coll), n, r.phi, g32)?;
            let dt = drummond_tahir_square_drag(r.phi);
            eprintln!(
                "{} {} {} phi={} n={n}: F/(mu U) {f:.4} vs {} ({:+.2}%), Drummond-Tahir \
                 {dt:.3} ({:+.2}%), voxel phi {phi_vox:.4}, Re {re:.2e}",
                ctx.id,
                r.lat.name(),
                r.coll.name(),
                r.phi,
                r.want,
                100.0 * (f / r.want - 1.0),
                100.0 * (f / dt - 1.0)
            );
            Ok(f)
        },
        |r, label, f| {
            let dt = drummond_tahir_square_drag(r.phi);
            if r.phi <= DRUMMOND_TAHIR_MAX_PHI {
                vec![Row::new(format!("{label} Drummond-Tahir"), f, dt, dt)]
            } else {
                Vec::new()
            }
        },
    )
}

/// Ends a resolution study: `sq` holds the sums of squared relative errors over `count` rows at
/// the coarse and the fine lattice; their RMS must fall, and any earlier `problems` fail it.
fn rms_must_fall(id: &str, sq: [f64; 2], count: usize, mut problems: Vec<String>) -> Result<()> {
    let rms = |s: f64| (s / count as f64).sqrt();
    eprintln!(
        "{id}: RMS relative error {:.3e} (coarse) -> {:.3e} (fine)",
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
    if problems.is_empty() {
        Ok(())
    } else {
        Err(Error::Validation(problems.join("; ")))
    }
}
