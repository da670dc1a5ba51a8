//! Shape validation cases:
//!
//! * 002 superquadric volume and inertia (thesis eq. 4.21, 4.29-4.31) against the independent
//!   nested Gauss-Kronrod oracle `reference/superquadric_volume_inertia.csv`
//!   (`porelab reference regen shape-quadrature`), the ellipsoid closed forms for g = 2, and
//!   the convergence to the box as the exponent grows;
//! * 003 spherocylinder volume and inertia (eq. 2.2-2.3) against the cylinder + hemispheres
//!   decomposition (expected.csv, `reference/scripts/spherocylinder_mpmath.py`) and the z-slice
//!   quadrature `reference/spherocylinder_volume_inertia.csv`.

use super::common::{self, loglog_slope, non_empty};
use crate::shape::{ConvexShape, Spherocylinder, Superquadric};
use crate::validation::{CaseContext, Row, Table};
use crate::{Error, Result};
use std::f64::consts::PI;

/// The oracle's estimate must be at most this fraction of the case's rtol (1e-13 for 002 and
/// 003), so that it cannot decide a row.
const ORACLE_LIMIT: f64 = 0.1 * 1e-13;

fn check_estimate(t: &Table, i: usize) -> Result<()> {
    common::check_estimate(t, i, ORACLE_LIMIT, "shape-quadrature")
}

const Q: [&str; 4] = ["volume_m3", "Ixx_m5", "Iyy_m5", "Izz_m5"];

fn quantities(s: &dyn ConvexShape) -> [f64; 4] {
    let i = s.principal_inertia_unit_density();
    [s.volume(), i.x, i.y, i.z]
}

register!("002" => case_002);
/// Case 002. Rows: V, Ixx, Iyy, Izz of every table row against the quadrature oracle (scale
/// |expected|); for g = (2, 2, 2) also against V = 4/3 pi a b c, Ixx = V (b^2 + c^2)/5.
/// Checked here (an error fails the case): the approach to the box 2a1 x 2a2 x 2a3 for equal
/// exponents g = 50..1000 (superball and supercuboid): with x = 1/g,
/// ln(V / 8abc) = 3 lnG(1+x) - lnG(1+3x) = -(pi^2/2) x^2 + O(x^3) and
/// ln(Ixx / Ixx_box) = -(7 pi^2/6) x^2 + O(x^3) (Ixx_box = 8abc (b^2 + c^2)/3; from
/// lnG(1+x) = -gamma x + zeta(2) x^2/2 + O(x^3)), so the relative deviations must fall with
/// fitted order 2 +- 0.02 and g^2 times the deviation at g = 1000 must be within 1% of pi^2/2
/// resp. 7 pi^2/6 (the O(1/g) correction is 8 zeta(3)/g relative to pi^2/2, 0.2% at g = 1000).
pub fn case_002(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    let mut box_pts: std::collections::BTreeMap<String, Vec<(f64, f64, f64)>> = Default::default();
    for i in 0..t.len() {
        check_estimate(&t, i)?;
        let fam = t.str(i, "family")?.to_string();
        let a = [t.f64(i, "a1_m")?, t.f64(i, "a2_m")?, t.f64(i, "a3_m")?];
        let g = [t.f64(i, "g1")?, t.f64(i, "g2")?, t.f64(i, "g3")?];
        let s = Superquadric::new(a, g)?;
        let got = quantities(&s);
        let label = format!(
            "{fam} a=({:e},{:e},{:e}) g=({},{},{})",
            a[0], a[1], a[2], g[0], g[1], g[2]
        );
        for k in 0..4 {
            let e = t.f64(i, Q[k])?;
            rows.push(Row::new(
                format!("{label} {} [quadrature]", Q[k]),
                got[k],
                e,
                e.abs(),
            ));
        }
        if g == [2.0, 2.0, 2.0] {
            let v = 4.0 / 3.0 * PI * a[0] * a[1] * a[2];
            let sq = a.map(|x| x * x);
            let closed = [
                v,
                v * (sq[1] + sq[2]) / 5.0,
                v * (sq[0] + sq[2]) / 5.0,
                v * (sq[0] + sq[1]) / 5.0,
            ];
            for k in 0..4 {
                rows.push(Row::new(
                    format!("{label} {} [4/3 pi abc closed form]", Q[k]),
                    got[k],
                    closed[k],
                    closed[k].abs(),
                ));
            }
        }
        if g[0] == g[1] && g[1] == g[2] && g[0] >= 50.0 {
            let vbox = 8.0 * a[0] * a[1] * a[2];
            let ibox = vbox * (a[1] * a[1] + a[2] * a[2]) / 3.0;
            box_pts
                .entry(format!("a=({},{},{})", a[0], a[1], a[2]))
                .or_default()
                .push((g[0], 1.0 - got[0] / vbox, 1.0 - got[1] / ibox));
        }
    }
    let mut problems = Vec::new();
    if box_pts.is_empty() {
        problems.push("no box-limit rows (equal exponents >= 50) in the table".to_string());
    }
    for (key, pts) in &box_pts {
        if pts.len() < 3 {
            problems.push(format!("{key}: fewer than 3 exponents >= 50"));
            continue;
        }
        for (which, idx, coef) in [
            ("V", 1usize, PI * PI / 2.0),
            ("Ixx", 2, 7.0 * PI * PI / 6.0),
        ] {
            let sel: Vec<(f64, f64)> = pts
                .iter()
                .map(|p| (p.0, if idx == 1 { p.1 } else { p.2 }))
                .collect();
            if sel.iter().any(|&(_, d)| !(d > 0.0 && d.is_finite())) {
                problems.push(format!(
                    "{key} {which}: deviation from the box not positive: {sel:?}"
                ));
                continue;
            }
            let order = -loglog_slope(&sel);
            if (order - 2.0).abs() > 0.02 {
                problems.push(format!(
                    "{key} {which}: relative deviation from the box falls as g^-{order:.4}, expected 2 +- 0.02"
                ));
            }
            let &(gmax, dmax) = sel
                .iter()
                .max_by(|x, y| x.0.partial_cmp(&y.0).unwrap())
                .unwrap();
            let c = dmax * gmax * gmax;
            if (c / coef - 1.0).abs() > 0.01 {
                problems.push(format!(
                    "{key} {which}: g^2 x deviation at g = {gmax} is {c:.6}, expected {coef:.6} within 1%"
                ));
            }
        }
    }
    if !problems.is_empty() {
        return Err(Error::Validation(format!(
            "box limit: {}",
            problems.join("; ")
        )));
    }
    Ok(rows)
}

register!("003" => case_003);
/// Case 003. Rows: V, Ixx, Iyy, Izz against the decomposition (expected.csv) and against the
/// z-slice quadrature (reference/spherocylinder_volume_inertia.csv); scale |expected|.
pub fn case_003(ctx: &CaseContext) -> Result<Vec<Row>> {
    let mut rows = Vec::new();
    for (source, t, with_est) in [
        ("cylinder+hemispheres", ctx.expected_table()?, false),
        (
            "z-slice quadrature",
            ctx.table("reference/spherocylinder_volume_inertia.csv")?,
            true,
        ),
    ] {
        non_empty(&t)?;
        for i in 0..t.len() {
            if with_est {
                check_estimate(&t, i)?;
            }
            let (r, l) = (t.f64(i, "radius_m")?, t.f64(i, "length_m")?);
            let s = Spherocylinder::new(r, l)?;
            let got = quantities(&s);
            for k in 0..4 {
                let e = t.f64(i, Q[k])?;
                rows.push(Row::new(
                    format!("R={r:e} L={l:e} {} [{source}]", Q[k]),
                    got[k],
                    e,
                    e.abs(),
                ));
            }
        }
    }
    Ok(rows)
}
