//! Orientational order parameters: nematic S (thesis eq. 2.11) and cubatic S4 (eq. 4.17).

use crate::error::invalid;
use crate::Result;
use nalgebra::{Matrix3, SymmetricEigen, UnitQuaternion, Vector3};

/// Nematic order parameter S (thesis eq. 2.11): the largest eigenvalue of
/// Q = (1/N) sum (3/2 u u^T - 1/2 I) over the unit axes u.
pub fn nematic_order(axes: &[Vector3<f64>]) -> Result<f64> {
    if axes.is_empty() {
        return invalid("no axes: nematic order needs at least one particle");
    }
    let mut q = Matrix3::zeros();
    for (i, u) in axes.iter().enumerate() {
        let nu = u.norm();
        if !(nu.is_finite() && nu > 0.0) {
            return invalid(format!(
                "axis {i} has norm {nu}: must be positive and finite"
            ));
        }
        let u = u / nu;
        q += 1.5 * u * u.transpose() - 0.5 * Matrix3::identity();
    }
    q /= axes.len() as f64;
    let e = SymmetricEigen::new(q).eigenvalues;
    Ok(e.max())
}

/// Cubatic order parameter S4 (thesis eq. 4.17, after Batten et al.):
/// max over unit n of (1/14N) sum_i sum_{j=1..3} (35 (u_ij.n)^4 - 30 (u_ij.n)^2 + 3), where
/// u_ij are the three body axes of particle i. 1 for perfect cubatic order, 0 on average for
/// isotropic orientations. The maximum is searched (as in the thesis) over trial directions
/// (a deterministic Fibonacci lattice of `trials` points on the half sphere), the best of which
/// are refined by projected gradient ascent.
pub fn cubatic_order(orientations: &[UnitQuaternion<f64>], trials: usize) -> Result<f64> {
    if orientations.is_empty() {
        return invalid("no orientations: cubatic order needs at least one particle");
    }
    if trials < 10 {
        return invalid(format!(
            "trials = {trials}: need at least 10 trial directions"
        ));
    }
    let axes: Vec<[Vector3<f64>; 3]> = orientations
        .iter()
        .map(|q| {
            let r = q.to_rotation_matrix();
            [
                r.matrix().column(0).into(),
                r.matrix().column(1).into(),
                r.matrix().column(2).into(),
            ]
        })
        .collect();
    let n_f = orientations.len() as f64;
    // sum_j c_j^2 = 1, so the summand is 35 sum_j c_j^4 - 21.
    let value = |n: &Vector3<f64>| -> f64 {
        let s: f64 = axes
            .iter()
            .map(|a| a.iter().map(|u| u.dot(n).powi(4)).sum::<f64>())
            .sum();
        (35.0 * s - 21.0 * n_f) / (14.0 * n_f)
    };
    let grad = |n: &Vector3<f64>| -> Vector3<f64> {
        let mut g = Vector3::zeros();
        for a in &axes {
            for u in a {
                g += 4.0 * u.dot(n).powi(3) * u;
            }
        }
        g * (35.0 / (14.0 * n_f))
    };
    // Fibonacci lattice on the upper half sphere (n and -n give the same value).
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut cand: Vec<(f64, Vector3<f64>)> = (0..trials)
        .map(|k| {
            let z = 1.0 - (k as f64 + 0.5) / trials as f64;
            let r = (1.0 - z * z).sqrt();
            let t = golden * k as f64;
            let n = Vector3::new(r * t.cos(), r * t.sin(), z);
            (value(&n), n)
        })
        .collect();
    cand.sort_by(|a, b| b.0.partial_cmp(&a.0).unwrap());
    let mut best = f64::NEG_INFINITY;
    for (v0, n0) in cand.into_iter().take(5) {
        let (mut v, mut n) = (v0, n0);
        let mut step = 0.1;
        for _ in 0..200 {
            let g = grad(&n);
            let gt = g - g.dot(&n) * n;
            if gt.norm() < 1e-14 {
                break;
            }
            let trial = (n + step * gt / gt.norm()).normalize();
            let vt = value(&trial);
            if vt > v {
                v = vt;
                n = trial;
                step *= 1.2;
            } else {
                step *= 0.5;
                if step < 1e-12 {
                    break;
                }
            }
        }
        best = best.max(v);
    }
    Ok(best)
}
