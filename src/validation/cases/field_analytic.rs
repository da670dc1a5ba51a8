//! Analytic validation cases of the finite-cylinder field (thesis 003, section 5.5):
//!
//! * 101 infinite-cylinder limit at the midplane (eq. 5.24, plus the derived O((R/L)^2)
//!   finite-length correction),
//! * 102 field on and next to the axis (eq. 5.26-5.27 and the solenoid formula),
//! * 103 far field: exact exterior multipole series, dipole limit (eq. 5.31, 5.35) and the
//!   (a/d)^2 approach to it,
//! * 105 Maxwell's equations from the exact gradient and the jump conditions at the surface,
//! * 106 rigid motions and superposition (checks the pose code, not the kernel).
//!
//! The tables of 101-103 are written by `reference/scripts/cylinder_limits_mpmath.py` (mpmath,
//! closed forms; no porelab code). 105 and 106 check laws (div B = 0, curl H = 0, jump
//! conditions, covariance, linearity) whose expected values are closed forms of the inputs.

use super::common::{loglog_slope, push_components, required_seed, v3};
use crate::consts::MU0;
use crate::magnetics::{Cylinder, Magnet};
use crate::validation::{CaseContext, Row};
use crate::{Error, Result};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const XYZ: [&str; 3] = ["x", "y", "z"];

/// Rows of a table of points with expected H (101, 102): H and B components. B is checked
/// against mu0 (H + M) inside / mu0 H outside, with the region taken from the table (not from
/// `Cylinder::contains`).
fn field_table_rows(ctx: &CaseContext, extra_label: &[&str]) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::with_capacity(6 * t.len());
    for i in 0..t.len() {
        let r = t.f64(i, "R_m")?;
        let l = t.f64(i, "L_m")?;
        let p = v3(&t, i, ["x_m", "y_m", "z_m"])?;
        let m = v3(&t, i, ["Mx_A_per_m", "My_A_per_m", "Mz_A_per_m"])?;
        let h_exp = v3(&t, i, ["Hx_A_per_m", "Hy_A_per_m", "Hz_A_per_m"])?;
        let scale = t.f64(i, "scale_A_per_m")?;
        let inside = t.str(i, "region")? == "inside";
        let cyl = Cylinder::new(r, l)?;
        let h = cyl.h_field(&m, &p);
        let b = cyl.b_field(&m, &p);
        let b_exp = MU0 * (h_exp + if inside { m } else { Vector3::zeros() });
        let mut tag = String::new();
        for c in extra_label {
            tag += t.str(i, c)?;
            tag += " ";
        }
        let where_ = format!(
            "{tag}L/R={:.3e} p=({:.4e},{:.4e},{:.4e})",
            l / r,
            p.x,
            p.y,
            p.z
        );
        push_components(&mut rows, "H", &where_, &h, &h_exp, scale);
        push_components(&mut rows, "B", &where_, &b, &b_exp, MU0 * scale);
    }
    Ok(rows)
}

register!("101" => case_101);
/// Case 101: infinite cylinder (eq. 5.24) at the midplane of cylinders with L/R = 1e6..1e8.
pub fn case_101(ctx: &CaseContext) -> Result<Vec<Row>> {
    field_table_rows(ctx, &["magnetization", "region"])
}

register!("102" => case_102);
/// Case 102: field on the axis and at rho = 1e-12 R (eq. 5.26-5.27, solenoid formula).
pub fn case_102(ctx: &CaseContext) -> Result<Vec<Row>> {
    field_table_rows(ctx, &["magnetization", "kind", "region"])
}

register!("103" => case_103);
/// Case 103: far field against the exact exterior multipole series (rows, rtol of case.toml),
/// and the convergence to the dipole (checked here; a violation is returned as an error):
/// along each ray, e(d) = |H - H_dip| / |H_dip| must fall as (a/d)^2 (fitted exponent
/// 2 +- 0.05 over d/a = 10..1000) and (d/a)^2 (H - H_dip)/|H_dip| must approach the analytic
/// quadrupole (l = 2) term within 1e-3 of its size at d/a = 1000; for L/R = sqrt(3)/2, where
/// q_2 = V (L^2/3 - R^2/4) = 0, the exponent must be 4 +- 0.1 (d/a = 4..100).
pub fn case_103(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::with_capacity(3 * t.len());
    // (aspect, magnetization, direction key) -> [(d/a, e(d), coefficient error)]
    let mut rays: std::collections::BTreeMap<String, Vec<(f64, f64, f64)>> = Default::default();
    for i in 0..t.len() {
        let r = t.f64(i, "R_m")?;
        let l = t.f64(i, "L_m")?;
        let aspect = t.str(i, "aspect_L_over_R")?;
        let mname = t.str(i, "magnetization")?;
        let dfac = t.f64(i, "d_over_a")?;
        let p = v3(&t, i, ["x_m", "y_m", "z_m"])?;
        let m = v3(&t, i, ["Mx_A_per_m", "My_A_per_m", "Mz_A_per_m"])?;
        let h_exp = v3(&t, i, ["Hx_A_per_m", "Hy_A_per_m", "Hz_A_per_m"])?;
        let h_dip = v3(
            &t,
            i,
            [
                "Hx_dipole_A_per_m",
                "Hy_dipole_A_per_m",
                "Hz_dipole_A_per_m",
            ],
        )?;
        let h_l2 = v3(&t, i, ["Hx_l2_A_per_m", "Hy_l2_A_per_m", "Hz_l2_A_per_m"])?;
        let scale = t.f64(i, "scale_A_per_m")?;
        let cyl = Cylinder::new(r, l)?;
        let h = cyl.h_field(&m, &p);
        let where_ = format!(
            "L/R={aspect} {mname} d/a={dfac:e} p=({:.4e},{:.4e},{:.4e})",
            p.x, p.y, p.z
        );
        push_components(&mut rows, "H", &where_, &h, &h_exp, scale);
        let u = p / p.norm();
        let key = format!(
            "L/R={aspect} {mname} dir=({:.3},{:.3},{:.3})",
            u.x, u.y, u.z
        );
        let dn = h_dip.norm();
        let e = (h - h_dip).norm() / dn;
        let coef_err = ((h - h_dip) - h_l2).norm() / h_l2.norm().max(f64::MIN_POSITIVE);
        rays.entry(key).or_default().push((dfac, e, coef_err));
    }
    let mut problems = Vec::new();
    for (key, pts) in &rays {
        let q2_zero = key.starts_with("L/R=sqrt3/2");
        let (lo, hi, order, tol) = if q2_zero {
            (4.0, 100.0, 4.0, 0.1)
        } else {
            (10.0, 1000.0, 2.0, 0.05)
        };
        let sel: Vec<(f64, f64)> = pts
            .iter()
            .filter(|(d, _, _)| *d >= lo && *d <= hi)
            .map(|&(d, e, _)| (d, e))
            .collect();
        if sel.len() < 3 {
            problems.push(format!("{key}: fewer than 3 distances in [{lo}, {hi}]"));
            continue;
        }
        if sel.iter().any(|&(_, e)| !(e.is_finite() && e > 0.0)) {
            problems.push(format!(
                "{key}: deviation from the dipole not finite/positive: {sel:?}"
            ));
            continue;
        }
        let slope = -loglog_slope(&sel);
        if (slope - order).abs() > tol {
            problems.push(format!(
                "{key}: |H - H_dip|/|H_dip| falls as (a/d)^{slope:.4}, expected {order} +- {tol}"
            ));
        }
        if !q2_zero {
            if let Some(&(_, _, ce)) = pts.iter().find(|(d, _, _)| *d == 1000.0) {
                if ce.is_nan() || ce > 1e-3 {
                    problems.push(format!(
                        "{key}: at d/a = 1000 (H - H_dip) differs from the l = 2 term by {ce:.3e} of it (allowed 1e-3)"
                    ));
                }
            }
        }
    }
    if !problems.is_empty() {
        return Err(Error::Validation(format!(
            "far-field convergence to the dipole failed on {} of {} rays:\n  {}",
            problems.len(),
            rays.len(),
            problems.join("\n  ")
        )));
    }
    Ok(rows)
}

/// Outward unit normal and a point on the surface of the cylinder (R, L): kind 0 lateral,
/// 1 top cap (z = L), 2 bottom cap (z = -L); rims excluded (5 % margin).
fn surface_point(
    rng: &mut ChaCha8Rng,
    r: f64,
    l: f64,
    kind: usize,
) -> (Vector3<f64>, Vector3<f64>) {
    let phi = rng.gen_range(0.0..std::f64::consts::TAU);
    let (s, c) = phi.sin_cos();
    match kind {
        0 => {
            // The point must lie on the surface in exact arithmetic (porelab tests R - rho
            // exactly, so a point 1e-20 R inside is inside): take one of the four azimuths
            // where x^2 + y^2 = R^2 holds exactly for doubles.
            let z = l * rng.gen_range(-0.95..0.95);
            let (c, s) = match rng.gen_range(0..4) {
                0 => (1.0, 0.0),
                1 => (0.0, 1.0),
                2 => (-1.0, 0.0),
                _ => (0.0, -1.0),
            };
            (Vector3::new(r * c, r * s, z), Vector3::new(c, s, 0.0))
        }
        _ => {
            let rho = r * 0.95 * rng.gen_range(0.0f64..1.0).sqrt();
            let sign = if kind == 1 { 1.0 } else { -1.0 };
            (
                Vector3::new(rho * c, rho * s, sign * l),
                Vector3::new(0.0, 0.0, sign),
            )
        }
    }
}

/// A random point off the surface: in a box around the cylinder, or at distance
/// 10^-u R (u in [1, 9]) from a random surface point, on either side.
fn off_surface_point(rng: &mut ChaCha8Rng, r: f64, l: f64) -> Vector3<f64> {
    loop {
        let p = if rng.gen_bool(0.5) {
            Vector3::new(
                rng.gen_range(-3.0 * r..3.0 * r),
                rng.gen_range(-3.0 * r..3.0 * r),
                rng.gen_range(-(3.0 * l + r)..(3.0 * l + r)),
            )
        } else {
            let kind = rng.gen_range(0..3usize);
            let (q, n) = surface_point(rng, r, l, kind);
            let d = r * 10f64.powf(-rng.gen_range(1.0..9.0));
            let side = if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
            q + side * d * n
        };
        let rho = p.x.hypot(p.y);
        if rho != r && p.z.abs() != l {
            return p;
        }
    }
}

fn frob(g: &Matrix3<f64>) -> f64 {
    g.norm()
}

register!("105" => case_105);
/// Case 105: Maxwell's equations from `h_gradient` and the jump conditions at the surface.
///
/// * Off the surface (random points, some down to 1e-9 R from it): div B = 0, i.e.
///   trace(dH/dx) = 0 (also inside: M is uniform), and curl H = 0, i.e. the antisymmetric
///   part of dH/dx vanishes; scale ||dH/dx||_F.
/// * Surface points p (lateral surface and caps, 5 % away from the rims), normal n,
///   delta = 1e-10 R: H and B at p +- delta n, moved back to p to first order with the
///   gradient (H(p) = H(p + delta n) - delta G n + O(delta^2 |dG|), the remainder below
///   1e-18 |M| here), give the jump H_out - H_in = (M.n) n (tangential H continuous,
///   normal H jumps by M.n) and B_out.n = B_in.n; scale |M| (mu0 |M| for B).
/// * The surface point itself is the outside limit: H(p) and B(p) equal the extrapolated
///   outside values; `contains` is false on the surface and at p + delta n, true at
///   p - delta n (rows with got/expected 1 or 0, scale 1).
pub fn case_105(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let seed = required_seed(ctx, "case 105 needs a seed in case.toml")?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let r = t.f64(i, "R_m")?;
        let l = t.f64(i, "L_m")?;
        let m = v3(&t, i, ["Mx_A_per_m", "My_A_per_m", "Mz_A_per_m"])?;
        let n_off = t.f64(i, "n_off_surface")? as usize;
        let n_surf = t.f64(i, "n_surface")? as usize;
        let delta = t.f64(i, "delta_over_R")? * r;
        let cfg = t.str(i, "config")?;
        let tr_exp = t.f64(i, "expected_trace_dHdx_A_per_m2")?;
        let anti_exp = t.f64(i, "expected_antisym_dHdx_A_per_m2")?;
        let cyl = Cylinder::new(r, l)?;
        let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(i as u64));
        let mn = m.norm();
        for _ in 0..n_off {
            let p = off_surface_point(&mut rng, r, l);
            let g = cyl.h_gradient(&m, &p);
            let s = frob(&g);
            let w = format!("{cfg} p=({:.6e},{:.6e},{:.6e})", p.x, p.y, p.z);
            rows.push(Row::new(format!("div {w}"), g.trace(), tr_exp, s));
            for (a, b) in [(0, 1), (1, 2), (2, 0)] {
                rows.push(Row::new(
                    format!("curl_{}{} {w}", XYZ[a], XYZ[b]),
                    g[(a, b)] - g[(b, a)],
                    anti_exp,
                    s,
                ));
            }
        }
        for j in 0..n_surf {
            let kind = j % 3;
            let (p, n) = surface_point(&mut rng, r, l, kind);
            let (po, pi) = (p + delta * n, p - delta * n);
            let (ho, hi) = (cyl.h_field(&m, &po), cyl.h_field(&m, &pi));
            let (go, gi) = (cyl.h_gradient(&m, &po), cyl.h_gradient(&m, &pi));
            let ho0 = ho - delta * go * n;
            let hi0 = hi + delta * gi * n;
            let bo0 = cyl.b_field(&m, &po) - MU0 * delta * go * n;
            let bi0 = cyl.b_field(&m, &pi) + MU0 * delta * gi * n;
            let jump = ho0 - hi0;
            let jump_exp = m.dot(&n) * n;
            let name = ["lateral", "top", "bottom"][kind];
            let w = format!("{cfg} {name} p=({:.6e},{:.6e},{:.6e})", p.x, p.y, p.z);
            push_components(&mut rows, "jump H", &w, &jump, &jump_exp, mn);
            rows.push(Row::new(
                format!("B.n continuous {w}"),
                bo0.dot(&n) - bi0.dot(&n),
                0.0,
                MU0 * mn,
            ));
            let hs = cyl.h_field(&m, &p);
            let bs = cyl.b_field(&m, &p);
            for k in 0..3 {
                rows.push(Row::new(
                    format!("surface H{} = outside limit {w}", XYZ[k]),
                    hs[k],
                    ho0[k],
                    mn,
                ));
                rows.push(Row::new(
                    format!("surface B{} = outside limit {w}", XYZ[k]),
                    bs[k],
                    MU0 * ho0[k],
                    MU0 * mn,
                ));
            }
            let b2f = |b: bool| if b { 1.0 } else { 0.0 };
            rows.push(Row::new(
                format!("contains(surface) {w}"),
                b2f(cyl.contains(&p)),
                0.0,
                1.0,
            ));
            rows.push(Row::new(
                format!("contains(p+dn) {w}"),
                b2f(cyl.contains(&po)),
                0.0,
                1.0,
            ));
            rows.push(Row::new(
                format!("contains(p-dn) {w}"),
                b2f(cyl.contains(&pi)),
                1.0,
                1.0,
            ));
        }
    }
    Ok(rows)
}

/// A uniformly distributed random rotation (normalized 4-D Gaussian quaternion).
fn random_rotation(rng: &mut ChaCha8Rng) -> UnitQuaternion<f64> {
    use rand_distr_free::normal;
    loop {
        let q = nalgebra::Quaternion::new(normal(rng), normal(rng), normal(rng), normal(rng));
        if q.norm() > 1e-3 {
            return UnitQuaternion::from_quaternion(q);
        }
    }
}

/// Standard normal deviates by Box-Muller (avoids a dependency on rand_distr).
mod rand_distr_free {
    use rand::Rng;
    pub fn normal(rng: &mut impl Rng) -> f64 {
        let u1: f64 = 1.0 - rng.gen::<f64>(); // (0, 1]
        let u2: f64 = rng.gen();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// A random local point at least 0.2 R from the surface, so that the rounding of the
/// world <-> local transform (a few ulp of |p| + |t|, |t| <= sqrt(3) R) moves H and its
/// gradient by at most ~ 3 * 4 eps (|p| + |t|) / (0.2 R) <~ 3e-13 relative (L/R = 20).
fn local_point(rng: &mut ChaCha8Rng, r: f64, l: f64) -> Vector3<f64> {
    loop {
        let p = Vector3::new(
            rng.gen_range(-2.5 * r..2.5 * r),
            rng.gen_range(-2.5 * r..2.5 * r),
            rng.gen_range(-(l + 1.5 * r)..(l + 1.5 * r)),
        );
        let rho = p.x.hypot(p.y);
        let d_lat = (rho - r).abs();
        let d_cap = (p.z.abs() - l).abs();
        let near_lat = d_lat < 0.2 * r && p.z.abs() <= l + 0.2 * r;
        let near_cap = d_cap < 0.2 * r && rho <= 1.2 * r;
        if !near_lat && !near_cap {
            return p;
        }
    }
}

register!("106" => case_106);
/// Case 106: rigid motions and superposition. For random poses (rotation Q, translation t;
/// fixed seed) the `Magnet` with axis Q z and world magnetization M must give
/// H(Q p + t) = Q H_cyl(Q^T M; p), B likewise, and dH/dx = Q G_cyl Q^T, where H_cyl is the
/// bare `Cylinder` in its own frame (the Magnet may pick a different twist about the axis:
/// the field of the axisymmetric body does not depend on it). Also linearity in M of the bare
/// cylinder: H(M1 + M2) = H(M1) + H(M2), H(a M) = a H(M), same for the gradient. The expected
/// values come from the Cylinder itself: this case checks the pose/rotation and superposition
/// code, not the field kernel (cases 101-105 and 104 do that).
pub fn case_106(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let seed = required_seed(ctx, "case 106 needs a seed in case.toml")?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let r = t.f64(i, "R_m")?;
        let l = t.f64(i, "L_m")?;
        let n_poses = t.f64(i, "n_poses")? as usize;
        let n_points = t.f64(i, "n_points_per_pose")? as usize;
        let m0 = t.f64(i, "M_A_per_m")?;
        let cfg = t.str(i, "config")?;
        let cyl = Cylinder::new(r, l)?;
        let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(1000 * i as u64));
        for k in 0..n_poses {
            let q = random_rotation(&mut rng);
            let qm = q.to_rotation_matrix();
            let tr = Vector3::new(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            ) * r;
            let mw = Vector3::new(
                rand_distr_free::normal(&mut rng),
                rand_distr_free::normal(&mut rng),
                rand_distr_free::normal(&mut rng),
            )
            .normalize()
                * m0;
            let axis = qm * Vector3::z();
            let magnet = Magnet::new(cyl, tr, axis, mw)?;
            let ml = qm.inverse() * mw;
            for j in 0..n_points {
                let p = local_point(&mut rng, r, l);
                let x = qm * p + tr;
                let w = format!("{cfg} pose {k} point {j}");
                let h_exp = qm * cyl.h_field(&ml, &p);
                let b_exp = qm * cyl.b_field(&ml, &p);
                let g_exp = qm.matrix() * cyl.h_gradient(&ml, &p) * qm.matrix().transpose();
                let (h, b, g) = (
                    magnet.h_field(&x),
                    magnet.b_field(&x),
                    magnet.h_gradient(&x),
                );
                let (hs, bs, gs) = (h_exp.norm(), b_exp.norm(), g_exp.norm());
                for c in 0..3 {
                    rows.push(Row::new(format!("H{} {w}", XYZ[c]), h[c], h_exp[c], hs));
                    rows.push(Row::new(format!("B{} {w}", XYZ[c]), b[c], b_exp[c], bs));
                    for d in 0..3 {
                        rows.push(Row::new(
                            format!("dH{}/d{} {w}", XYZ[c], XYZ[d]),
                            g[(c, d)],
                            g_exp[(c, d)],
                            gs,
                        ));
                    }
                }
                // linearity of the bare cylinder in M (local frame)
                let m1 = ml;
                let m2 = Vector3::new(
                    rand_distr_free::normal(&mut rng),
                    rand_distr_free::normal(&mut rng),
                    rand_distr_free::normal(&mut rng),
                ) * m0;
                let a: f64 = rng.gen_range(-3.0..3.0);
                let (h1, h2) = (cyl.h_field(&m1, &p), cyl.h_field(&m2, &p));
                let h12 = cyl.h_field(&(m1 + m2), &p);
                let ha = cyl.h_field(&(a * m1), &p);
                let (g1, g2) = (cyl.h_gradient(&m1, &p), cyl.h_gradient(&m2, &p));
                let g12 = cyl.h_gradient(&(m1 + m2), &p);
                let sum_scale = h1.norm() + h2.norm();
                let gsum_scale = g1.norm() + g2.norm();
                for c in 0..3 {
                    rows.push(Row::new(
                        format!("H{}(M1+M2) {w}", XYZ[c]),
                        h12[c],
                        h1[c] + h2[c],
                        sum_scale,
                    ));
                    rows.push(Row::new(
                        format!("H{}(aM) a={a:.3} {w}", XYZ[c]),
                        ha[c],
                        a * h1[c],
                        a.abs() * h1.norm(),
                    ));
                    for d in 0..3 {
                        rows.push(Row::new(
                            format!("dH{}/d{}(M1+M2) {w}", XYZ[c], XYZ[d]),
                            g12[(c, d)],
                            g1[(c, d)] + g2[(c, d)],
                            gsum_scale,
                        ));
                    }
                }
            }
        }
    }
    Ok(rows)
}
