//! Case 201: Happel-Brenner translational resistance of ellipsoids (seed 000 eq. A3-A11)
//! against Perrin's closed forms for spheroids, Stokes' law, the disk limits and direct
//! quadrature of the integral definitions eq. A6-A7 for triaxial ellipsoids (table written by
//! `reference/scripts/happel_brenner_mpmath.py`; no Carlson integrals there).

use super::common::loglog_slope;
use crate::hydro::{principal_resistances, resistance_tensor};
use crate::validation::{CaseContext, Row};
use crate::{Error, Result};
use nalgebra::{Quaternion, UnitQuaternion};
use std::f64::consts::PI;

/// Sphere rows must reproduce 6 pi mu a to this relative error (about 9 ulp).
const SPHERE_RTOL: f64 = 2e-15;

register!("201" => case_201);
/// Case 201. One row per table row (C_a, C_b, C_c, f = 3/sum(1/C), or a tensor entry T_ij for
/// a rotated body), scale from the table. Checked here as well (an error fails the case):
/// sphere rows within 2e-15 of 6 pi mu a; the approach of thin oblates (a = b = 1, c -> 0) to
/// the disk: edgewise C/(32 mu a/3) - 1 ~ (8/(3 pi)) c/a (fitted order 1 +- 0.02 over
/// c/a = 1e-8..1e-3, coefficient within 1e-3 at c/a = 1e-8) and broadside C/(16 mu a) - 1 ~
/// (c/a)^2 / 2 (order 2 +- 0.02 over c/a = 1e-5..1e-2, coefficient within 1e-3 at 1e-5), the
/// expansions of Perrin's oblate forms.
pub fn case_201(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::with_capacity(t.len());
    let mut problems = Vec::new();
    for i in 0..t.len() {
        let kind = t.str(i, "kind")?.to_string();
        let axes = [t.f64(i, "a_m")?, t.f64(i, "b_m")?, t.f64(i, "c_m")?];
        let mu = t.f64(i, "viscosity_Pa_s")?;
        let q = t.str(i, "quantity")?.to_string();
        let expected = t.f64(i, "expected_N_s_per_m")?;
        let scale = t.f64(i, "scale_N_s_per_m")?;
        let c = principal_resistances(axes, mu)?;
        let got = match q.as_str() {
            "Ca" => c[0],
            "Cb" => c[1],
            "Cc" => c[2],
            "f" => crate::hydro::mobility_averaged_resistance(axes, mu)?,
            s if s.len() == 3 && s.starts_with('T') => {
                let ij: Vec<usize> = s[1..]
                    .chars()
                    .map(|ch| ch.to_digit(10).map(|d| d as usize))
                    .collect::<Option<Vec<_>>>()
                    .filter(|v| v.iter().all(|&d| d < 3))
                    .ok_or_else(|| Error::Validation(format!("bad quantity '{s}'")))?;
                let quat = UnitQuaternion::from_quaternion(Quaternion::new(
                    t.f64(i, "qw")?,
                    t.f64(i, "qx")?,
                    t.f64(i, "qy")?,
                    t.f64(i, "qz")?,
                ));
                resistance_tensor(axes, mu, &quat)?[(ij[0], ij[1])]
            }
            other => {
                return Err(Error::Validation(format!(
                    "{} line {}: unknown quantity '{other}'",
                    t.path().display(),
                    t.line(i)
                )))
            }
        };
        if kind == "sphere" && (got - expected).abs() > SPHERE_RTOL * expected.abs() {
            problems.push(format!(
                "sphere a={:e} mu={mu:e} {q}: {got:e} differs from 6 pi mu a = {expected:e} by {:.2e} relative (allowed {SPHERE_RTOL:e})",
                axes[0],
                (got - expected).abs() / expected.abs()
            ));
        }
        rows.push(Row::new(
            format!(
                "{kind} ({:e},{:e},{:e}) m mu={mu:e} {q}",
                axes[0], axes[1], axes[2]
            ),
            got,
            expected,
            scale,
        ));
    }
    // Approach to the disk.
    let dev = |c: f64, k: usize, lim: f64| -> Result<f64> {
        Ok(principal_resistances([1.0, 1.0, c], 1.0)?[k] / lim - 1.0)
    };
    for (which, k, lim, lo, hi, order, coef) in [
        ("edgewise", 0usize, 32.0 / 3.0, 8, 3, 1.0, 8.0 / (3.0 * PI)),
        ("broadside", 2usize, 16.0, 5, 2, 2.0, 0.5),
    ] {
        let mut pts = Vec::new();
        for e in hi..=lo {
            let c = 10f64.powi(-e);
            pts.push((c, dev(c, k, lim)?));
        }
        if pts.iter().any(|&(_, d)| !(d > 0.0 && d.is_finite())) {
            problems.push(format!(
                "{which}: deviation from the disk limit not positive: {pts:?}"
            ));
            continue;
        }
        let p = loglog_slope(&pts);
        if (p - order).abs() > 0.02 {
            problems.push(format!(
                "{which}: C approaches the disk limit as (c/a)^{p:.4}, expected {order} +- 0.02"
            ));
        }
        let (c0, d0) = pts[pts.len() - 1];
        let got = d0 / c0.powf(order);
        if (got / coef - 1.0).abs() > 1e-3 {
            problems.push(format!(
                "{which}: (C/limit - 1)/(c/a)^{order} at c/a = {c0:e} is {got:.6}, expected {coef:.6} within 1e-3"
            ));
        }
    }
    if !problems.is_empty() {
        return Err(Error::Validation(problems.join("; ")));
    }
    Ok(rows)
}
