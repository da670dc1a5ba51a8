//! Cases 801-806: the lattice-Boltzmann engine against closed forms (plane Poiseuille,
//! Guo & Zhao's Brinkman channel, Taylor-Green decay, nu(tau) of seed 002 eq. 8) and the
//! literature table of Zick & Homsy (1982) for simple cubic sphere arrays.

use crate::driver::NoHooks;
use crate::lbm::flows::{
    brinkman_poiseuille, channel_coordinate, cylinder_array_fractions, cylinder_array_mask,
    drag_coefficient, drummond_tahir_square_drag, poiseuille, sangani_acrivos_sc,
    sphere_array_fractions, sphere_array_mask,
};
use crate::lbm::ladder::observed_order;
use crate::lbm::problems::{permeability, taylor_green_viscosity, Channel, ChannelFlow};
use crate::lbm::{
    CollisionKind, CollisionModel, Dims, Domain, LatticeKind, SteadyControl, Tau, WallRule, Walls,
};
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
/// array cell, the solid `mask` on `dims` with the walls `walls`, under body force g along x;
/// `diameter` (cells) is the Reynolds number's length. Refuses a run that did not reach the
/// steady state.
fn array_cell(
    (lat, coll): (LatticeKind, CollisionModel),
    dims: Dims,
    (mask, walls): (Vec<bool>, Walls),
    diameter: f64,
    g: f64,
) -> Result<(f64, f64, f64)> {
    let domain = Domain::with_solid(dims, mask)?.with_walls(walls)?;
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
    (g16, walls): (f64, WallRule),
) -> Result<(f64, f64, f64)> {
    let radius = n as f64 * (3.0 * phi / (4.0 * std::f64::consts::PI)).cbrt();
    let g = g16 * (16.0 / n as f64).powi(3);
    let mask = sphere_array_mask(n, radius);
    let walls = walls.walls(|| sphere_array_fractions(n, radius))?;
    array_cell(scheme, Dims::new(n, n, n)?, (mask, walls), 2.0 * radius, g)
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
        let stairs = WallRule::Staircase;
        let (k_ref, _, re_ref) = sphere_array_k(at(tau_ref)?, n, phi, (g_ref, stairs))?;
        let (k, _, re) = sphere_array_k(at(tau)?, n, phi, (g, stairs))?;
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
    walls: WallRule,
}

/// Whether row `i` is checked ("check") or only printed beside the checked rows ("report");
/// `kind` column, "check" where absent.
fn checked(t: &Table, i: usize) -> Result<bool> {
    if t.col("kind").is_err() {
        return Ok(true);
    }
    match t.str(i, "kind")? {
        "check" => Ok(true),
        "report" => Ok(false),
        k => Err(Error::Validation(format!(
            "{} line {}: kind = \"{k}\": must be \"check\" or \"report\"",
            t.path().display(),
            t.line(i)
        ))),
    }
}

/// The wall rule of row `i` (`walls` column; "staircase" where absent).
fn walls_of(t: &Table, i: usize) -> Result<WallRule> {
    if t.col("walls").is_err() {
        return Ok(WallRule::Staircase);
    }
    WallRule::parse(t.str(i, "walls")?, "walls")
}

/// The observable of one array flow: `(row, n, table, line) -> value` at n cells.
type Measure<'a> = dyn FnMut(&StudyRow, usize, &Table, usize) -> Result<f64> + 'a;

/// A resolution study over the rows of expected.csv: `measure(row, n, table, i)` gives the
/// observable on the n_coarse and the n_fine lattice; the fine value of a checked row is
/// checked against the literature column `want_col` (plus the rows `extra(row, label, fine)`
/// adds), and the RMS error over the checked rows must fall from coarse to fine ("report"
/// rows, the staircase comparison, are printed only). `check(row)` names a problem with the
/// literature input itself (an input check, not the code under test). Then the rows of
/// tau.csv and order.csv ([`tau_rows`], [`order_rows`]) where the case has them.
fn resolution_study(
    ctx: &CaseContext,
    want_col: &str,
    check: impl Fn(&StudyRow) -> Option<String>,
    measure: &mut Measure,
    extra: impl Fn(&StudyRow, &str, f64) -> Vec<Row>,
) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    let mut problems = Vec::new();
    let mut sq = [[0.0; 2]; 2];
    let mut count = [0; 2];
    for i in 0..t.len() {
        let (lat, coll) = scheme(&t, i)?;
        let r = StudyRow {
            lat,
            coll,
            phi: t.f64(i, "phi")?,
            want: t.f64(i, want_col)?,
            walls: walls_of(&t, i)?,
        };
        let is_checked = checked(&t, i)?;
        problems.extend(check(&r));
        let group = is_checked as usize;
        count[group] += 1;
        for (j, col) in ["n_coarse", "n_fine"].into_iter().enumerate() {
            let n = whole_n(&t, i, col)?;
            let got = measure(&r, n, &t, i)?;
            sq[group][j] += (got / r.want - 1.0).powi(2);
            if j == 1 && is_checked {
                let label = format!(
                    "{} {} {} walls phi={} n={n}",
                    lat.name(),
                    coll.name(),
                    r.walls.name(),
                    r.phi
                );
                rows.extend(extra(&r, &label, got));
                rows.push(Row::new(label, got, r.want, r.want));
            }
        }
    }
    if count[0] > 0 {
        let rms = |s: f64| (s / count[0] as f64).sqrt();
        eprintln!(
            "{}: report rows (not checked): RMS relative error {:.3e} (coarse) -> {:.3e} (fine)",
            ctx.id,
            rms(sq[0][0]),
            rms(sq[0][1])
        );
    }
    // the staircase error of one particle is not monotone in n; its RMS over the table must fall
    rms_must_fall(&ctx.id, sq[1], count[1], problems)?;
    rows.extend(tau_rows(ctx, want_col, measure)?);
    rows.extend(order_rows(ctx, want_col, measure)?);
    Ok(rows)
}

/// Column `col` of row `i` as a lattice size: a whole number >= 8.
fn whole_n(t: &Table, i: usize, col: &str) -> Result<usize> {
    let n = t.f64(i, col)?;
    if !(n.is_finite() && n >= 8.0 && n.fract() == 0.0) {
        return Err(Error::Validation(format!(
            "{} line {}: {col} = {n}: must be a whole number >= 8",
            t.path().display(),
            t.line(i)
        )));
    }
    Ok(n as usize)
}

/// The inputs of a row of tau.csv or order.csv at relaxation time `tau`.
fn side_row(t: &Table, i: usize, want_col: &str, tau: f64) -> Result<StudyRow> {
    let (lat, kind) = kinds(t, i)?;
    Ok(StudyRow {
        lat,
        coll: CollisionModel::new(kind, Tau::new(tau)?),
        phi: t.f64(i, "phi")?,
        want: t.f64(i, want_col)?,
        walls: walls_of(t, i)?,
    })
}

/// Rows of the case's tau.csv, if any: the observable at `tau` relative to it at `tau_ref`
/// (same lattice n, walls and force) against 1, the tolerance rtol x `scale` (TRT with
/// Lambda = 3/16 and walls whose place does not depend on tau: the steady flow does not).
fn tau_rows(ctx: &CaseContext, want_col: &str, measure: &mut Measure) -> Result<Vec<Row>> {
    if !ctx.case_dir.join("tau.csv").exists() {
        return Ok(Vec::new());
    }
    let t = ctx.table("tau.csv")?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let n = whole_n(&t, i, "n")?;
        let (tau_ref, tau) = (t.f64(i, "tau_ref")?, t.f64(i, "tau")?);
        let a = side_row(&t, i, want_col, tau_ref)?;
        let b = side_row(&t, i, want_col, tau)?;
        let (va, vb) = (measure(&a, n, &t, i)?, measure(&b, n, &t, i)?);
        let label = format!(
            "{} {} {} walls phi={} n={n} tau {tau_ref}->{tau}",
            a.lat.name(),
            a.coll.name(),
            a.walls.name(),
            a.phi
        );
        eprintln!("{} {label}: ratio {:.6}", ctx.id, vb / va);
        rows.push(Row::new(label, vb / va, 1.0, t.f64(i, "scale")?));
    }
    Ok(rows)
}

/// Rows of the case's order.csv, if any: the order p for which the observable on three lattices
/// n1 < n2 < n3 lies on v_inf + c n^-p ([`observed_order`], no literature value involved)
/// against `expected_order`, the tolerance rtol x `scale`.
fn order_rows(ctx: &CaseContext, want_col: &str, measure: &mut Measure) -> Result<Vec<Row>> {
    if !ctx.case_dir.join("order.csv").exists() {
        return Ok(Vec::new());
    }
    let t = ctx.table("order.csv")?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let r = side_row(&t, i, want_col, t.f64(i, "tau")?)?;
        let n = [
            whole_n(&t, i, "n1")?,
            whole_n(&t, i, "n2")?,
            whole_n(&t, i, "n3")?,
        ];
        let mut v = [0.0; 3];
        for k in 0..3 {
            v[k] = measure(&r, n[k], &t, i)?;
        }
        let label = format!(
            "{} {} {} walls phi={} n={}/{}/{} observed order",
            r.lat.name(),
            r.coll.name(),
            r.walls.name(),
            r.phi,
            n[0],
            n[1],
            n[2]
        );
        // no monotone approach: no order (NaN fails the row)
        let p = observed_order(n, v).unwrap_or(f64::NAN);
        eprintln!("{} {label}: {p:.3} (values {v:?})", ctx.id);
        rows.push(Row::new(
            label,
            p,
            t.f64(i, "expected_order")?,
            t.f64(i, "scale")?,
        ));
    }
    Ok(rows)
}

register!("806", "807" => case_806_807);
/// Cases 806 (slow, the whole table) and 807 (fast, a subset): simple cubic sphere arrays, drag
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
        &mut |r, n, t, i| {
            let radius = n as f64 * (3.0 * r.phi / (4.0 * std::f64::consts::PI)).cbrt();
            let g16 = t.f64(i, "g16_lattice")?;
            let (k, _, re) = sphere_array_k((r.lat, r.coll), n, r.phi, (g16, r.walls))?;
            // K from the nominal radius and solid fraction (the staircase is the error measured)
            let kd = drag_coefficient(k, radius, r.phi);
            eprintln!(
                "806 {} {} tau={} {} phi={} n={n}: K {kd:.4} vs {} ({:+.2}%), Re {re:.2e}",
                r.lat.name(),
                r.coll.name(),
                r.coll.tau.get(),
                r.walls.name(),
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
    (g32, walls): (f64, WallRule),
) -> Result<(f64, f64, f64)> {
    // phi = pi a^2 / L^2
    let radius = n as f64 * (phi / std::f64::consts::PI).sqrt();
    let mask = cylinder_array_mask(n, 1, radius);
    let walls = walls.walls(|| cylinder_array_fractions(n, 1, radius))?;
    let g = g32 * (32.0 / n as f64).powi(3);
    let dims = Dims::new(n, n, 1)?;
    let (k, phi_voxels, re) = array_cell(scheme, dims, (mask, walls), 2.0 * radius, g)?;
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
        &mut |r, n, t, i| {
            let g32 = t.f64(i, "g32_lattice")?;
            let (f, phi_vox, re) = cylinder_array_drag((r.lat, r.coll), n, r.phi, (g32, r.walls))?;
            let dt = drummond_tahir_square_drag(r.phi);
            eprintln!(
                "{} {} {} tau={} {} phi={} n={n}: F/(mu U) {f:.4} vs {} ({:+.2}%), \
                 Drummond-Tahir {dt:.3} ({:+.2}%), voxel phi {phi_vox:.4}, Re {re:.2e}",
                ctx.id,
                r.lat.name(),
                r.coll.name(),
                r.coll.tau.get(),
                r.walls.name(),
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
