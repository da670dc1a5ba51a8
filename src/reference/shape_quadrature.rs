//! Independent quadrature oracle for the volume and the principal moments of inertia (unit
//! density) of superquadrics and spherocylinders; writes
//! `reference/superquadric_volume_inertia.csv` and `reference/spherocylinder_volume_inertia.csv`.
//!
//! Nothing here uses Gamma functions, the thesis' closed forms or `crate::shape`.
//!
//! **Superquadric** |x/a1|^g1 + |y/a2|^g2 + |z/a3|^g3 <= 1. By symmetry the integrals are 8 times
//! those over the first octant, and with x = a1 xi, y = a2 eta, z = a3 zeta (an exact change of
//! variables) V = 8 a1 a2 a3 J\[1\], int x^2 = 8 a1^3 a2 a3 J\[xi^2\], int y^2 = 8 a1 a2^3 a3 J\[eta^2\],
//! int z^2 = 8 a1 a2 a3^3 J\[zeta^2\], J\[f\] = int over the unit-axes octant body of f. J is computed
//! as nested one-dimensional integrals over z-slices with the analytic cross-section boundary:
//! for a slice at zeta the section is xi^g1 + eta^g2 <= h = 1 - zeta^g3, xi runs over
//! [0, h^(1/g1)], and for each xi the eta integral is done exactly (eta from 0 to
//! eta_max = (h - xi^g1)^(1/g2): int 1 = eta_max, int eta^2 = eta_max^3 / 3).
//! Both remaining integrals (xi, then zeta) use the adaptive Gauss-Kronrod G10/K21 rule of
//! `special::quadrature`. Each has an algebraic endpoint singularity (eta_max ~ (distance)^(1/g2)
//! at the slice rim, the slice integrals ~ (1 - zeta)^(1/g1 + 1/g2) at the top), so both are
//! written in the distance to that endpoint (xi = xi_max (1 - e), zeta = 1 - e_z) with
//! 1 - (1 - e)^g = -expm1(g ln1p(-e)) (no cancellation near the endpoint) and pre-split at
//! e = 2^-k, k = 1..60, which also resolves the boundary layer of width ~ 1/g of large exponents.
//! Each of the four integrals is computed on its own. Its error estimate is the outer estimate
//! plus the integral over zeta of the inner estimates (carried as a second component); a row's
//! `est_rel_err` is the largest of the four estimates relative to their integrals.
//!
//! **Spherocylinder** (radius R, cylinder length L, axis z): slices are disks of radius rho(z),
//! rho^2 = R^2 for |z| <= L/2 and (R - w)(R + w), w = |z| - L/2, on the caps. Per slice: area
//! pi rho^2, int x^2 = pi rho^4 / 4, int z^2 = z^2 pi rho^2; the z integral is split at L/2 and
//! done by the same G-K rule (the slice integrands are polynomials of degree <= 4 on each piece,
//! so the rule is exact up to rounding).

use crate::special::quadrature::integrate;
use crate::Result;
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::Path;

/// Relative tolerance asked of each nested integral.
const RTOL: f64 = 1e-15;

fn breaks() -> Vec<f64> {
    (1..=60).rev().map(|k| 0.5f64.powi(k)).collect()
}

/// 1 - (1 - e)^g without cancellation for small e.
fn one_minus_pow(e: f64, g: f64) -> f64 {
    -(g * (-e).ln_1p()).exp_m1()
}

/// First-octant integrals over the unit-axes superquadric with exponents g:
/// \[J\[1\], J\[xi^2\], J\[eta^2\], J\[zeta^2\]\] and the absolute error estimate of each (every
/// component is integrated on its own, so each estimate refers to that component alone).
pub fn superquadric_octant(g: [f64; 3]) -> ([f64; 4], [f64; 4]) {
    let mut val = [0.0; 4];
    let mut err = [0.0; 4];
    for k in 0..4 {
        (val[k], err[k]) = octant_component(g, k);
    }
    (val, err)
}

/// One component k of [`superquadric_octant`]: (value, absolute error estimate).
fn octant_component(g: [f64; 3], k: usize) -> (f64, f64) {
    let br = breaks();
    // Inner integral over xi at fixed zeta (slice height h), in e = 1 - xi / xi_max; the
    // eta integral is exact. Returns [value, error estimate].
    let inner = |h: f64, zeta: f64| -> [f64; 2] {
        if h <= 0.0 {
            return [0.0; 2];
        }
        let xi_max = h.powf(1.0 / g[0]);
        let r = integrate::<1, _, _>(
            |e| {
                let eta = (h * one_minus_pow(e, g[0])).powf(1.0 / g[1]);
                let f = match k {
                    0 => eta,
                    1 => {
                        let xi = xi_max * (1.0 - e);
                        xi * xi * eta
                    }
                    2 => eta * eta * eta / 3.0,
                    _ => zeta * zeta * eta,
                };
                [f]
            },
            0.0,
            1.0,
            &br,
            |v| RTOL * v[0].abs(),
            4000,
        );
        [xi_max * r.value[0], xi_max * r.abs_err]
    };
    let outer = integrate::<2, _, _>(
        |ez| inner(one_minus_pow(ez, g[2]), 1.0 - ez),
        0.0,
        1.0,
        &br,
        |v| RTOL * v[0].abs(),
        4000,
    );
    // The outer estimate is the norm over both components; it bounds the value's error.
    (outer.value[0], outer.abs_err + outer.value[1].abs())
}

/// Volume, principal inertia at unit density (Ixx, Iyy, Izz) and the relative error estimate
/// (the largest over the four integrals of its error estimate relative to its value; the
/// moments Ixx = int y^2 + int z^2 etc. are sums of positive terms, so this bounds them too).
pub fn superquadric_oracle(a: [f64; 3], g: [f64; 3]) -> (f64, [f64; 3], f64) {
    let (j, err) = superquadric_octant(g);
    let p = 8.0 * a[0] * a[1] * a[2];
    let v = p * j[0];
    let m = [
        p * a[0] * a[0] * j[1],
        p * a[1] * a[1] * j[2],
        p * a[2] * a[2] * j[3],
    ];
    // The scale factors multiply exactly up to 4 roundings, the sums add one more.
    let rel = (0..4).map(|k| err[k] / j[k]).fold(0.0, f64::max) + 5.0 * f64::EPSILON;
    (v, [m[1] + m[2], m[0] + m[2], m[0] + m[1]], rel)
}

/// Volume, principal inertia at unit density (Ixx = Iyy, Izz) and the relative error estimate.
pub fn spherocylinder_oracle(r: f64, l: f64) -> (f64, [f64; 3], f64) {
    let h = 0.5 * l;
    let f = |z: f64| -> [f64; 3] {
        let rho2 = if z <= h {
            r * r
        } else {
            let w = z - h;
            (r - w) * (r + w)
        };
        let area = std::f64::consts::PI * rho2;
        [area, area * rho2 / 4.0, z * z * area]
    };
    let brk: Vec<f64> = if h > 0.0 { vec![h] } else { vec![] };
    // Each component on its own, so that each estimate refers to that component alone.
    let mut val = [0.0; 3];
    let mut rel: f64 = 0.0;
    for (k, out) in val.iter_mut().enumerate() {
        let q = integrate::<1, _, _>(|z| [f(z)[k]], 0.0, h + r, &brk, |v| RTOL * v[0].abs(), 4000);
        *out = 2.0 * q.value[0];
        rel = rel.max(q.abs_err / q.value[0].abs());
    }
    let [v, mx, mz] = val;
    (v, [mx + mz, mx + mz, 2.0 * mx], rel + 2.0 * f64::EPSILON)
}

/// The superquadrics of the table: (label, semi-axes, exponents).
pub fn superquadric_cases() -> Vec<(&'static str, [f64; 3], [f64; 3])> {
    let mut v = vec![
        ("ellipsoid", [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]),
        ("ellipsoid", [1.0, 2.0, 3.0], [2.0, 2.0, 2.0]),
        ("ellipsoid", [2.5e-6, 1e-6, 4e-7], [2.0, 2.0, 2.0]),
        ("ellipsoid", [100.0, 1.0, 1.0], [2.0, 2.0, 2.0]),
    ];
    for g in [2.5, 4.0, 8.0, 20.0] {
        v.push(("superball", [1.0, 1.0, 1.0], [g, g, g]));
        v.push(("supercuboid", [1.0, 0.5, 2.0], [g, g, g]));
    }
    v.extend([
        ("mixed", [1.0, 0.8, 0.5], [2.0, 4.0, 8.0]),
        ("mixed", [0.3, 1.0, 2.0], [20.0, 2.5, 3.0]),
        ("mixed", [1e-3, 2e-3, 5e-4], [2.0, 2.0, 20.0]),
        ("mixed", [1.0, 1.0, 10.0], [8.0, 2.5, 2.0]),
    ]);
    for g in [50.0, 100.0, 200.0, 500.0, 1000.0] {
        v.push(("box-limit", [1.0, 1.0, 1.0], [g, g, g]));
        v.push(("box-limit", [1.0, 0.5, 2.0], [g, g, g]));
    }
    v
}

/// The spherocylinders of the table: (radius, length).
pub fn spherocylinder_cases() -> Vec<(f64, f64)> {
    vec![
        (1.0, 0.0),
        (0.5, 1.0),
        (0.5, 4.0),
        (1.0, 0.1),
        (1e-6, 2.4e-5),
        (0.01, 100.0),
        (3.0, 1e-3),
    ]
}

fn e17(x: f64) -> String {
    format!("{x:.16e}")
}

/// Generator `shape-quadrature`: both tables.
pub fn regen_shape_quadrature(reference_dir: &Path) -> Result<()> {
    let t0 = std::time::Instant::now();
    let sq = superquadric_cases();
    let res: Vec<_> = sq
        .par_iter()
        .map(|(_, a, g)| superquadric_oracle(*a, *g))
        .collect();
    let mut csv =
        String::from("family,a1_m,a2_m,a3_m,g1,g2,g3,volume_m3,Ixx_m5,Iyy_m5,Izz_m5,est_rel_err\n");
    for ((fam, a, g), (v, i, e)) in sq.iter().zip(&res) {
        let _ = writeln!(
            csv,
            "{fam},{},{},{},{},{},{},{},{},{},{},{:.2e}",
            e17(a[0]),
            e17(a[1]),
            e17(a[2]),
            g[0],
            g[1],
            g[2],
            e17(*v),
            e17(i[0]),
            e17(i[1]),
            e17(i[2]),
            e
        );
    }
    super::write_file(reference_dir, "superquadric_volume_inertia.csv", csv)?;
    let worst = res.iter().map(|r| r.2).fold(0.0, f64::max);
    eprintln!(
        "superquadric_volume_inertia.csv: {} rows, worst est_rel_err {worst:.2e}",
        sq.len()
    );
    let sc = spherocylinder_cases();
    let mut csv = String::from("radius_m,length_m,volume_m3,Ixx_m5,Iyy_m5,Izz_m5,est_rel_err\n");
    for (r, l) in &sc {
        let (v, i, e) = spherocylinder_oracle(*r, *l);
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{:.2e}",
            e17(*r),
            e17(*l),
            e17(v),
            e17(i[0]),
            e17(i[1]),
            e17(i[2]),
            e
        );
    }
    super::write_file(reference_dir, "spherocylinder_volume_inertia.csv", csv)?;
    eprintln!(
        "spherocylinder_volume_inertia.csv: {} rows; {:.2} s",
        sc.len(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn sphere_octant() {
        // Unit ball: V = 4 pi / 3, int x^2 = 4 pi / 15.
        let (j, err) = superquadric_octant([2.0, 2.0, 2.0]);
        assert!((8.0 * j[0] - 4.0 * PI / 3.0).abs() < 1e-14, "{j:?}");
        assert!((8.0 * j[1] - 4.0 * PI / 15.0).abs() < 1e-14, "{j:?}");
        assert!(err.iter().all(|&e| e < 1e-14), "{err:?}");
    }
}
