//! Helpers shared by tests/contact_oracle.rs and benches/contact.rs (included with `#[path]`;
//! not a test target): the superquadric support map handed to parry, written from the closed
//! form (not taken from porelab), and the pose-to-isometry conversion.

use nalgebra::{Isometry3, Point3, Translation3, Vector3};
use porelab::contact::Pose;

/// Support point of the superquadric sum |x_k/a_k|^g_k = 1 in direction `d`: bisection in
/// ln mu over [-ln_mu_range, ln_mu_range] (`iters` halvings) on the Lagrange multiplier mu of
/// max d.x, with |x_k/a_k| = (|d_k| a_k / (mu g_k))^(1/(g_k - 1)) (sum |x_k/a_k|^g_k is
/// decreasing in mu).
pub fn sq_support_point(
    a: [f64; 3],
    g: [f64; 3],
    d: &Vector3<f64>,
    ln_mu_range: f64,
    iters: usize,
) -> Point3<f64> {
    let x_of = |mu: f64| {
        Vector3::from_fn(|k, _| {
            if d[k] == 0.0 {
                0.0
            } else {
                a[k] * (d[k].abs() * a[k] / (mu * g[k])).powf(1.0 / (g[k] - 1.0)) * d[k].signum()
            }
        })
    };
    let s = |mu: f64| {
        let x = x_of(mu);
        (0..3).map(|k| (x[k] / a[k]).abs().powf(g[k])).sum::<f64>()
    };
    let (mut lo, mut hi) = (-ln_mu_range, ln_mu_range);
    for _ in 0..iters {
        let mid = 0.5 * (lo + hi);
        if s(mid.exp()) > 1.0 {
            lo = mid
        } else {
            hi = mid
        }
    }
    Point3::from(x_of((0.5 * (lo + hi)).exp()))
}

/// The isometry of a porelab pose.
pub fn iso(p: &Pose) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(p.position), p.orientation)
}
