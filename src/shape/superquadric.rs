//! Superquadric (thesis 003 section 4.2, eq. 4.3-4.6):
//! |x/a1|^g1 + |y/a2|^g2 + |z/a3|^g3 <= 1, semi-axes a_i > 0, exponents g_i >= 2 (convex;
//! g = 2 on every axis is the ellipsoid, g -> infinity the box 2a1 x 2a2 x 2a3). The
//! parametrisation of eq. 4.5 uses eps_i = 2/g_i.
//!
//! **Volume and inertia (eq. 4.21, 4.29-4.31).** With the identity x Gamma(x) = Gamma(1 + x)
//! the thesis' factors eps_i Gamma(eps_i/2) = 2 Gamma(1 + 1/g_i) and
//! eps_i Gamma(3 eps_i/2) = (2/3) Gamma(1 + 3/g_i), so
//!   V = 8 a1 a2 a3 G(1/g1) G(1/g2) G(1/g3) / Gamma(1 + 1/g1 + 1/g2 + 1/g3),  G(x) = Gamma(1 + x),
//!   int y^2 dV = (8/3) a1 a2^3 a3 G(1/g1) G(3/g2) G(1/g3) / Gamma(1 + 1/g1 + 3/g2 + 1/g3)
//! (and cyclic), Ixx = int (y^2 + z^2) dV etc. Every Gamma argument lies in [1, 3.5] whatever
//! the exponents (no overflow as g -> infinity, unlike eps Gamma(eps/2) in the thesis' form); the
//! Gamma ratio is formed as exp of a sum of ln Gamma (`libm::lgamma`, a port of the FreeBSD
//! msun lgamma_r, error below 1 ulp on this range) and multiplied by the lengths.
//!
//! **Bounding radius (appendix 4.C).** The radius of the smallest centred sphere is
//! max |x| on the surface (eq. 4.35 says "minimize", but the enveloping sphere is the
//! *maximum* of x^2 + y^2 + z^2 on the surface, as eq. 4.36 says). With u_i = x_i^2 / a_i^2 this
//! is max sum a_i^2 u_i subject to sum u_i^(g_i/2) = 1. For equal exponents the closed form
//! eq. 4.38 is used (evaluated with the largest a_i^2 factored out so that the power
//! 1/(1 - eps) cannot overflow near g = 2; g = 2 gives max a_i). Otherwise the same problem is
//! solved through its convex dual (see `power_ball_max`), a one-dimensional monotone
//! root-finding that returns an upper bound at any iterate and the exact value at convergence.
//!
//! **Support point.** The surface point whose normal (eq. 4.6) is parallel to d: with
//! t_i = |x_i|/a_i, n_i ~ (g_i/a_i) t_i^(g_i - 1) = lambda^-1 |d_i| gives
//! t_i = (a_i |d_i| / (lambda g_i))^(1/(g_i - 1)), and lambda follows from sum t_i^g_i = 1, a
//! monotone equation in ln lambda solved by Newton's method on its log-sum-exp form (convex,
//! so the iterates approach the root monotonically from a bracket end); this is the maximiser
//! of d . x over the body (Hoelder duality) and stays accurate for g up to 1e3 and more.
//!
//! The implicit function is eq. 4.3, F = sum |x_i/a_i|^g_i - 1.

use super::{area_weighted_samples, check_length, ConvexShape};
use crate::error::{invalid, Result};
use nalgebra::Vector3;

/// A superquadric (eq. 4.3) with semi-axes a_i and exponents g_i >= 2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Superquadric {
    a: [f64; 3],
    g: [f64; 3],
}

impl Superquadric {
    /// Semi-axes a_i (positive, finite) and exponents g_i (finite, >= 2 for convexity).
    pub fn new(semi_axes: [f64; 3], exponents: [f64; 3]) -> Result<Superquadric> {
        for (k, &v) in semi_axes.iter().enumerate() {
            check_length(&format!("superquadric semi-axis a{}", k + 1), v)?;
        }
        for (k, &g) in exponents.iter().enumerate() {
            if !(g.is_finite() && g >= 2.0) {
                return invalid(format!(
                    "superquadric exponent g{} = {g}: must be finite and >= 2 (exponents below 2 give a non-convex shape)",
                    k + 1
                ));
            }
        }
        Ok(Superquadric {
            a: semi_axes,
            g: exponents,
        })
    }

    /// Semi-axes (a1, a2, a3).
    pub fn semi_axes(&self) -> [f64; 3] {
        self.a
    }

    /// Exponents (g1, g2, g3).
    pub fn exponents(&self) -> [f64; 3] {
        self.g
    }

    /// int x_k^2 dV (k = 0, 1, 2) or, with `k = None`, V. The Gamma factor is exp of a sum of
    /// ln Gamma of arguments in [1, 3.5] (|sum| < 3, so a few ulp); the lengths multiply it
    /// directly (taking their logarithms into the sum would cost |ln a| ulp).
    fn moment(&self, k: Option<usize>) -> f64 {
        let mut s = 0.0;
        let mut arg = 1.0;
        for i in 0..3 {
            let p = if Some(i) == k { 3.0 } else { 1.0 };
            let x = p / self.g[i];
            s += libm::lgamma(1.0 + x);
            arg += x;
        }
        s -= libm::lgamma(arg);
        let [a1, a2, a3] = self.a;
        let base = 8.0 * s.exp() * (a1 * a2 * a3);
        match k {
            None => base,
            Some(i) => base * self.a[i] * self.a[i] / 3.0,
        }
    }

    /// Second moments int x^2 dV, int y^2 dV, int z^2 dV at unit density.
    pub fn second_moments(&self) -> Vector3<f64> {
        Vector3::new(
            self.moment(Some(0)),
            self.moment(Some(1)),
            self.moment(Some(2)),
        )
    }

    /// Distance from the centre to the surface along the unit direction v.
    fn radial(&self, v: &Vector3<f64>) -> f64 {
        // ln S(s) = ln sum exp(g_i (s + ln(|v_i|/a_i))) = 0, s = ln r; convex increasing, Newton
        // from the right end (the nearest face) converges monotonically.
        let mut b = [f64::NEG_INFINITY; 3];
        let mut s = f64::INFINITY;
        for i in 0..3 {
            if v[i] != 0.0 {
                b[i] = (v[i].abs() / self.a[i]).ln();
                s = s.min(-b[i]);
            }
        }
        for _ in 0..200 {
            let e: Vec<f64> = (0..3).map(|i| self.g[i] * (s + b[i])).collect();
            let m = e.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let (mut sum, mut dsum) = (0.0, 0.0);
            for i in 0..3 {
                if b[i].is_finite() {
                    let w = (e[i] - m).exp();
                    sum += w;
                    dsum += self.g[i] * w;
                }
            }
            let lns = m + sum.ln();
            let step = lns / (dsum / sum);
            s -= step;
            if step.abs() <= 2.0 * f64::EPSILON * s.abs().max(1.0) {
                break;
            }
        }
        s.exp()
    }
}

/// Maximises sum w_i t_i subject to sum t_i^q_i = 1, t_i >= 0 (w_i >= 0, q_i >= 1, not all
/// w_i zero). Returns the maximiser t and the maximum, computed as the value of the convex
/// dual D(lambda) = lambda + sum sup_t (w_i t - lambda t^q_i)
/// = lambda (1 + sum (q_i - 1) t_i(lambda)^q_i), t_i(lambda) = (w_i / (lambda q_i))^(1/(q_i - 1)),
/// at its minimiser (D >= the maximum for every lambda, and D is stationary at the optimum, so
/// the returned value is insensitive to the root's last digits). Terms with q_i = 1 contribute
/// 0 for lambda >= w_i and take any slack when the optimum is lambda = max w_i over them.
pub(crate) fn power_ball_max(w: [f64; 3], q: [f64; 3]) -> ([f64; 3], f64) {
    let mut t = [0.0; 3];
    let pow_idx: Vec<usize> = (0..3).filter(|&i| w[i] > 0.0 && q[i] > 1.0).collect();
    let lin_idx: Vec<usize> = (0..3).filter(|&i| w[i] > 0.0 && q[i] <= 1.0).collect();
    let c: Vec<f64> = (0..3).map(|i| w[i].ln() - q[i].ln()).collect();
    let beta: Vec<f64> = (0..3).map(|i| q[i] / (q[i] - 1.0)).collect();
    // ln S(s), S(s) = sum over pow_idx of t_i^q_i = exp(beta_i (c_i - s)); and -d lnS/ds.
    let ln_s = |s: f64| -> (f64, f64) {
        let e: Vec<f64> = pow_idx.iter().map(|&i| beta[i] * (c[i] - s)).collect();
        let m = e.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let (mut sum, mut dsum) = (0.0, 0.0);
        for (k, &i) in pow_idx.iter().enumerate() {
            let x = (e[k] - m).exp();
            sum += x;
            dsum += beta[i] * x;
        }
        (m + sum.ln(), dsum / sum)
    };
    let lin_best = lin_idx
        .iter()
        .copied()
        .max_by(|&i, &j| w[i].partial_cmp(&w[j]).unwrap());
    let s_final;
    if let Some(kb) = lin_best {
        let s0 = w[kb].ln();
        let slack = if pow_idx.is_empty() {
            1.0
        } else {
            1.0 - ln_s(s0).0.exp()
        };
        if slack >= 0.0 {
            let lambda = w[kb];
            let mut d = 1.0;
            for &i in &pow_idx {
                t[i] = ((c[i] - s0) / (q[i] - 1.0)).exp();
                d += (q[i] - 1.0) * (beta[i] * (c[i] - s0)).exp();
            }
            t[kb] = slack;
            return (t, lambda * d);
        }
        s_final = s0;
    } else {
        s_final = pow_idx
            .iter()
            .map(|&i| c[i])
            .fold(f64::NEG_INFINITY, f64::max);
    }
    // Newton on the convex decreasing ln S from the left end of the bracket (ln S >= 0 there):
    // monotone convergence to the root.
    let n = pow_idx.len() as f64;
    let hi = pow_idx
        .iter()
        .map(|&i| c[i] + n.ln() / beta[i])
        .fold(f64::NEG_INFINITY, f64::max);
    let mut s = s_final;
    for _ in 0..200 {
        let (l, dl) = ln_s(s);
        if l <= 0.0 {
            break;
        }
        let next = (s + l / dl).min(hi.max(s));
        if next - s <= 2.0 * f64::EPSILON * s.abs().max(1.0) {
            s = next;
            break;
        }
        s = next;
    }
    let mut d = 1.0;
    for &i in &pow_idx {
        t[i] = ((c[i] - s) / (q[i] - 1.0)).exp();
        d += (q[i] - 1.0) * (beta[i] * (c[i] - s)).exp();
    }
    (t, s.exp() * d)
}

impl ConvexShape for Superquadric {
    /// Eq. 4.21 (rewritten with Gamma(1 + x), see the module notes).
    fn volume(&self) -> f64 {
        self.moment(None)
    }

    /// Eq. 4.29-4.31 at unit density.
    fn principal_inertia_unit_density(&self) -> Vector3<f64> {
        let m = self.second_moments();
        Vector3::new(m.y + m.z, m.x + m.z, m.x + m.y)
    }

    /// Eq. 4.38 for equal exponents, the dual one-dimensional maximisation otherwise.
    fn bounding_radius(&self) -> f64 {
        let [a1, a2, a3] = self.a;
        let sq = [a1 * a1, a2 * a2, a3 * a3];
        let amax = sq.iter().cloned().fold(0.0, f64::max);
        if self.g[0] == self.g[1] && self.g[1] == self.g[2] {
            let eps = 2.0 / self.g[0];
            if eps >= 1.0 {
                return amax.sqrt();
            }
            let p = 1.0 / (1.0 - eps);
            let s: f64 = sq.iter().map(|&x| (x / amax).powf(p)).sum();
            return (amax * s.powf(1.0 - eps)).sqrt();
        }
        let w = [sq[0] / amax, sq[1] / amax, sq[2] / amax];
        let q = [0.5 * self.g[0], 0.5 * self.g[1], 0.5 * self.g[2]];
        let (_, r2) = power_ball_max(w, q);
        (amax * r2).sqrt()
    }

    /// Eq. 4.3: sum |x_i/a_i|^g_i - 1 (+infinity far outside for large g).
    fn implicit(&self, p: &Vector3<f64>) -> f64 {
        (0..3)
            .map(|i| (p[i] / self.a[i]).abs().powf(self.g[i]))
            .sum::<f64>()
            - 1.0
    }

    /// Eq. 4.6 normalised, formed in logarithms (no overflow for large g); +z at the centre.
    fn normal(&self, p: &Vector3<f64>) -> Vector3<f64> {
        let mut l = [f64::NEG_INFINITY; 3];
        for i in 0..3 {
            if p[i] != 0.0 {
                l[i] = (self.g[i] / self.a[i]).ln()
                    + (self.g[i] - 1.0) * (p[i].abs() / self.a[i]).ln();
            }
        }
        let m = l.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        if !m.is_finite() {
            return Vector3::z();
        }
        let n =
            Vector3::from_fn(|i, _| (l[i] - m).exp().copysign(p[i]) * (p[i] != 0.0) as u8 as f64);
        n / n.norm()
    }

    /// The surface point with normal parallel to d (module notes); the +z pole for d = 0.
    fn support(&self, d: &Vector3<f64>) -> Vector3<f64> {
        let m = d.amax();
        if !m.is_finite() || m <= 0.0 {
            return Vector3::new(0.0, 0.0, self.a[2]);
        }
        let du = d / m;
        let w = [
            self.a[0] * du.x.abs(),
            self.a[1] * du.y.abs(),
            self.a[2] * du.z.abs(),
        ];
        let (t, _) = power_ball_max(w, self.g);
        Vector3::from_fn(|i, _| (self.a[i] * t[i]).copysign(du[i]))
    }

    fn surface_samples(&self, n: usize) -> Vec<Vector3<f64>> {
        area_weighted_samples(
            n,
            Vector3::from(self.a),
            |v| self.radial(v),
            |p| self.normal(p),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::Ellipsoid;
    use std::f64::consts::PI;

    #[test]
    fn ellipsoid_limit() {
        let s = Superquadric::new([1.0, 2.0, 3.0], [2.0, 2.0, 2.0]).unwrap();
        let e = Ellipsoid::new([1.0, 2.0, 3.0]).unwrap();
        assert!((s.volume() - 8.0 * PI).abs() < 4e-15 * 8.0 * PI);
        let (is, ie) = (
            s.principal_inertia_unit_density(),
            e.principal_inertia_unit_density(),
        );
        for k in 0..3 {
            assert!((is[k] - ie[k]).abs() < 4e-15 * ie[k], "{is:?} {ie:?}");
        }
        assert_eq!(s.bounding_radius(), 3.0);
        let d = Vector3::new(0.3, -0.2, 0.7);
        assert!((s.support(&d) - e.support(&d)).norm() < 1e-14);
        let p = e.support(&d);
        assert!((s.normal(&p) - e.normal(&p)).norm() < 1e-14);
    }

    #[test]
    fn box_limit_and_no_overflow() {
        let s = Superquadric::new([1.0, 2.0, 0.5], [1e3, 1e3, 1e3]).unwrap();
        let v = s.volume();
        assert!(v.is_finite() && (v / 8.0 - 1.0).abs() < 1e-5, "{v}");
        let i = s.principal_inertia_unit_density();
        assert!((i.x / (8.0 * (4.0 + 0.25) / 3.0) - 1.0).abs() < 1e-4);
        let r = s.bounding_radius();
        assert!((r - (1.0f64 + 4.0 + 0.25).sqrt()).abs() < 1e-2, "{r}");
        let p = s.support(&Vector3::new(1.0, 1.0, 1.0));
        assert!(s.implicit(&p).abs() < 1e-12, "{p:?}");
    }

    #[test]
    fn bounding_radius_general_matches_closed_form_and_samples() {
        // Equal exponents: the dual solver must reproduce eq. 4.38.
        for g in [2.0, 2.000001, 2.5, 4.0, 20.0, 1000.0] {
            let s = Superquadric::new([1.0, 0.7, 0.3], [g, g, g]).unwrap();
            let closed = s.bounding_radius();
            let sq = [1.0, 0.49, 0.09];
            let (_, r2) = power_ball_max(sq, [g / 2.0; 3]);
            assert!(
                (r2.sqrt() - closed).abs() < 1e-13 * closed,
                "g={g}: {} vs {closed}",
                r2.sqrt()
            );
        }
        // Mixed exponents: no surface sample beyond the radius, and some sample close to it.
        for (a, g) in [
            ([1.0, 0.8, 0.5], [2.0, 4.0, 8.0]),
            ([0.2, 1.0, 0.5], [20.0, 2.0, 3.0]),
            ([1.0, 1.0, 1.0], [2.0, 2.0, 50.0]),
        ] {
            let s = Superquadric::new(a, g).unwrap();
            let r = s.bounding_radius();
            let pts = s.surface_samples(20000);
            let rmax = pts.iter().map(|p| p.norm()).fold(0.0, f64::max);
            assert!(rmax <= r * (1.0 + 1e-14), "{a:?} {g:?}: {rmax} > {r}");
            assert!(rmax > r * (1.0 - 2e-3), "{a:?} {g:?}: {rmax} << {r}");
        }
    }

    #[test]
    fn support_normal_parallel() {
        let s = Superquadric::new([1.0, 0.5, 2.0], [2.5, 8.0, 20.0]).unwrap();
        for d in [
            Vector3::new(1.0, 2.0, 3.0),
            Vector3::new(-1.0, 0.0, 1e-9),
            Vector3::new(0.0, 0.0, -1.0),
        ] {
            let p = s.support(&d);
            assert!(s.implicit(&p).abs() < 1e-13, "{p:?}");
            assert!(
                (s.normal(&p) - d.normalize()).norm() < 1e-9,
                "{:?}",
                s.normal(&p)
            );
            // d . p is the maximum over the surface samples.
            let best = s
                .surface_samples(5000)
                .iter()
                .map(|q| q.dot(&d))
                .fold(f64::NEG_INFINITY, f64::max);
            assert!(best <= p.dot(&d) * (1.0 + 1e-13));
        }
        for q in s.surface_samples(300) {
            assert!(s.implicit(&q).abs() < 1e-12);
        }
    }

    #[test]
    fn random_directions_extreme_exponents() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for g in [
            [2.0, 2.0, 2.0],
            [2.0, 2.0001, 3.0],
            [1000.0, 2.0, 20.0],
            [1000.0, 1000.0, 1000.0],
            [2.5, 1e3, 7.0],
        ] {
            let s = Superquadric::new([1.0, 0.01, 0.3], g).unwrap();
            let r = s.bounding_radius();
            let samples = s.surface_samples(4000);
            assert!(
                samples.iter().all(|q| q.norm() <= r * (1.0 + 1e-14)),
                "g={g:?}: sample beyond the bounding radius {r}"
            );
            for _ in 0..200 {
                let mut d = Vector3::new(
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                );
                // Some directions with tiny components.
                if rng.gen_bool(0.2) {
                    d.y *= 1e-200;
                }
                let p = s.support(&d);
                assert!(p.iter().all(|x| x.is_finite()), "g={g:?} d={d:?}");
                assert!(
                    s.implicit(&p).abs() < 1e-12,
                    "g={g:?} d={d:?} F={}",
                    s.implicit(&p)
                );
                assert!(p.norm() <= r * (1.0 + 1e-14));
                let best = samples
                    .iter()
                    .map(|q| q.dot(&d))
                    .fold(f64::NEG_INFINITY, f64::max);
                assert!(best <= p.dot(&d) + 1e-14 * d.norm(), "g={g:?} d={d:?}");
            }
        }
    }

    #[test]
    fn bad_exponent() {
        let e = Superquadric::new([1.0; 3], [2.0, 1.5, 2.0])
            .unwrap_err()
            .to_string();
        assert!(e.contains("g2 = 1.5") && e.contains(">= 2"), "{e}");
        assert!(Superquadric::new([1.0, 0.0, 1.0], [2.0; 3]).is_err());
        assert!(Superquadric::new([1.0; 3], [2.0, f64::INFINITY, 2.0]).is_err());
    }
}
