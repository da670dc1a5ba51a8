//! Forces of the Brownian-dynamics engine (thesis 003, eq. 6.12, 6.18–6.23, 7.5–7.7), SI units.

use crate::consts::MU0;
use crate::error::{invalid, require_positive, Result};
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::PI;

/// Shifted and truncated Mie(n, m) repulsion (eq. 6.18–6.19) between spheres of diameter
/// `sigma` = 2R: U(r) = C eps [(sigma/r)^n - (sigma/r)^m] + eps for r < r_min, 0 beyond, with
/// C = (n/(n-m)) (n/m)^(m/(n-m)) and r_min = sigma (n/m)^(1/(n-m)), where the unshifted
/// potential has its minimum -eps. Energy in J, lengths in m, forces in N.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mie {
    pub n: i32,
    pub m: i32,
    /// eps (J).
    pub epsilon: f64,
    /// sigma = 2R (m).
    pub sigma: f64,
    prefactor: f64,
    r_min: f64,
}

impl Mie {
    /// n > m >= 1 (integers), eps > 0, sigma > 0, all finite.
    pub fn new(n: i32, m: i32, epsilon: f64, sigma: f64) -> Result<Mie> {
        if !(m >= 1 && n > m) {
            return invalid(format!(
                "Mie exponents (n, m) = ({n}, {m}): need integers n > m >= 1"
            ));
        }
        require_positive(epsilon, || format!("Mie epsilon = {epsilon} J"))?;
        require_positive(sigma, || {
            format!("Mie sigma (particle diameter) = {sigma} m")
        })?;
        let (nf, mf) = (n as f64, m as f64);
        let prefactor = nf / (nf - mf) * (nf / mf).powf(mf / (nf - mf));
        let r_min = sigma * (nf / mf).powf(1.0 / (nf - mf));
        Ok(Mie {
            n,
            m,
            epsilon,
            sigma,
            prefactor,
            r_min,
        })
    }
    /// The thesis default: Mie(30, 15) with eps = 100 kB T, for particles of radius `radius`.
    pub fn thesis_default(kt: f64, radius: f64) -> Result<Mie> {
        Mie::new(30, 15, 100.0 * kt, 2.0 * radius)
    }
    /// C = (n/(n-m)) (n/m)^(m/(n-m)).
    pub fn prefactor(&self) -> f64 {
        self.prefactor
    }
    /// Position of the minimum of the unshifted potential, also the cut-off (m).
    pub fn r_min(&self) -> f64 {
        self.r_min
    }
    /// Unshifted, untruncated Mie energy (eq. 6.18), J.
    pub fn energy_unshifted(&self, r: f64) -> f64 {
        let s = self.sigma / r;
        self.prefactor * self.epsilon * (s.powi(self.n) - s.powi(self.m))
    }
    /// Shifted-truncated energy (eq. 6.19), J.
    pub fn energy(&self, r: f64) -> f64 {
        if r < self.r_min {
            self.energy_unshifted(r) + self.epsilon
        } else {
            0.0
        }
    }
    /// -dU/dr (N, positive = repulsive) of the shifted-truncated potential; 0 for r >= r_min.
    pub fn force_magnitude(&self, r: f64) -> f64 {
        if r >= self.r_min {
            return 0.0;
        }
        let s = self.sigma / r;
        self.prefactor * self.epsilon / r
            * (self.n as f64 * s.powi(self.n) - self.m as f64 * s.powi(self.m))
    }
    /// Force (N) on particle i for the separation `rij` = r_i - r_j (m).
    pub fn pair_force(&self, rij: &Vector3<f64>) -> Vector3<f64> {
        let r = rij.norm();
        if r >= self.r_min {
            return Vector3::zeros();
        }
        rij * (self.force_magnitude(r) / r)
    }
}

/// Dipole–dipole energy (eq. 6.21), J: U = -(mu0 / 4 pi) [3 (r.a)(r.b) / r^5 - (a.b) / r^3]
/// for moments a, b (A m^2) separated by `r` (m).
pub fn dipole_energy(r: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let d2 = r.norm_squared();
    let d = d2.sqrt();
    let d3 = d2 * d;
    -MU0 / (4.0 * PI) * (3.0 * r.dot(a) * r.dot(b) / (d3 * d2) - a.dot(b) / d3)
}

/// Force (N) on dipole a at r_i from dipole b at r_j, `r` = r_i - r_j (eq. 6.23):
/// F = -grad_{r_i} U = (3 mu0 / (4 pi r^5)) [(r.b) a + (r.a) b + (a.b) r - 5 (r.a)(r.b) r / r^2].
pub fn dipole_force(r: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> Vector3<f64> {
    let d2 = r.norm_squared();
    let d = d2.sqrt();
    let ra = r.dot(a);
    let rb = r.dot(b);
    let c = 3.0 * MU0 / (4.0 * PI * d2 * d2 * d);
    (a * rb + b * ra + r * a.dot(b) - r * (5.0 * ra * rb / d2)) * c
}

/// Langevin function L(x) = coth x - 1/x (eq. 6.22, 7.5), odd, L(x) ~ x/3 near 0 (eq. 7.7),
/// L(x) -> 1 - 1/x for large x. Without cancellation near 0: for |x| <= 2 it is evaluated as
/// (x cosh x - sinh x) / (x sinh x) with the numerator summed as the positive series
/// sum_{k>=1} 2k x^(2k+1) / (2k+1)!; for |x| < 1e-5 as x/3 (1 - x^2/15).
pub fn langevin(x: f64) -> f64 {
    let ax = x.abs();
    if ax.is_nan() {
        return f64::NAN;
    }
    let v = if ax < 1e-5 {
        ax / 3.0 * (1.0 - ax * ax / 15.0)
    } else if ax <= 2.0 {
        let x2 = ax * ax;
        // term_k = 2k x^(2k+1)/(2k+1)!; p = x^(2k+1)/(2k+1)!
        let mut p = ax * x2 / 6.0;
        let mut sum = 2.0 * p;
        let mut k = 1.0f64;
        loop {
            p *= x2 / ((2.0 * k + 2.0) * (2.0 * k + 3.0));
            k += 1.0;
            let t = 2.0 * k * p;
            sum += t;
            if t < 1e-18 * sum || k > 60.0 {
                break;
            }
        }
        sum / (ax * ax.sinh())
    } else {
        1.0 / ax.tanh() - 1.0 / ax
    };
    v.copysign(x)
}

/// How a particle's magnetic moment follows the local field H (moment along H).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LangevinMoment {
    /// Superparamagnetic: |m| = m_s L(mu0 mu_d |H| / kB T) (eq. 6.22 per particle), with the
    /// saturation moment m_s and the single-domain moment mu_d (both A m^2). At kB T = 0 the
    /// moment is saturated.
    Langevin { saturation: f64, domain: f64 },
    /// Fixed magnitude (A m^2) along H (Table 6.1 moments, saturated in ~1 T).
    Fixed(f64),
}

impl LangevinMoment {
    pub fn langevin(saturation: f64, domain: f64) -> Result<LangevinMoment> {
        for (name, v) in [("saturation moment", saturation), ("domain moment", domain)] {
            require_positive(v, || format!("{name} = {v} A m^2"))?;
        }
        Ok(LangevinMoment::Langevin { saturation, domain })
    }
    pub fn fixed(moment: f64) -> Result<LangevinMoment> {
        if !(moment.is_finite() && moment >= 0.0) {
            return invalid(format!(
                "particle moment = {moment} A m^2: must be finite and >= 0"
            ));
        }
        Ok(LangevinMoment::Fixed(moment))
    }
    /// The saturated moment (A m^2): the fixed moment, or the saturation moment m_s.
    pub fn saturation(&self) -> f64 {
        match *self {
            LangevinMoment::Fixed(m) => m,
            LangevinMoment::Langevin { saturation, .. } => saturation,
        }
    }
    /// Magnitude of the moment (A m^2) in a field of magnitude `h` (A/m) at thermal energy `kt` (J).
    pub fn magnitude(&self, h: f64, kt: f64) -> f64 {
        match *self {
            LangevinMoment::Fixed(m) => m,
            LangevinMoment::Langevin { saturation, domain } => {
                if h == 0.0 {
                    0.0
                } else if kt == 0.0 {
                    saturation
                } else {
                    saturation * langevin(MU0 * domain * h / kt)
                }
            }
        }
    }
    /// The moment vector (A m^2) in the field `h` (A/m): along H; zero where H = 0.
    pub fn moment(&self, h: &Vector3<f64>, kt: f64) -> Vector3<f64> {
        let hn = h.norm();
        if hn == 0.0 {
            return Vector3::zeros();
        }
        h * (self.magnitude(hn, kt) / hn)
    }
}

/// A magnetic field source: H (A/m) and its gradient G (A/m^2), G[(i, j)] = dH_i/dx_j, at a
/// point (m). `porelab::magnetics::{Magnet, Assembly}` implement it; wrap a closure in
/// [`FieldFn`], add a uniform field with [`WithUniform`].
pub trait FieldSource: Send + Sync {
    fn h_and_gradient(&self, p: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>);
}

impl FieldSource for crate::magnetics::Magnet {
    fn h_and_gradient(&self, p: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        crate::magnetics::Magnet::h_and_gradient(self, p)
    }
}

impl FieldSource for crate::magnetics::Assembly {
    fn h_and_gradient(&self, p: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        crate::magnetics::Assembly::h_and_gradient(self, p)
    }
}

/// A closure p -> (H, dH_i/dx_j) as a field source.
pub struct FieldFn<F>(pub F);

impl<F> FieldSource for FieldFn<F>
where
    F: Fn(&Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) + Send + Sync,
{
    fn h_and_gradient(&self, p: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        (self.0)(p)
    }
}

/// A source plus a uniform applied field H0 (A/m) (e.g. 1 T along x: H0 = (1/mu0, 0, 0)).
pub struct WithUniform<S> {
    pub h0: Vector3<f64>,
    pub source: S,
}

impl<S: FieldSource> FieldSource for WithUniform<S> {
    fn h_and_gradient(&self, p: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        let (h, g) = self.source.h_and_gradient(p);
        (h + self.h0, g)
    }
}

/// A uniform field H0 (A/m), zero gradient.
pub struct Uniform(pub Vector3<f64>);

impl FieldSource for Uniform {
    fn h_and_gradient(&self, _p: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        (self.0, Matrix3::zeros())
    }
}

/// Force (N) on a point dipole `m` (A m^2) in a field with gradient `grad_h` (A/m^2,
/// grad_h[(i, j)] = dH_i/dx_j): F = mu0 (m . grad) H, F_i = mu0 sum_j m_j dH_i/dx_j.
/// Outside magnetized matter B = mu0 H, so this is eq. 6.20, (m . grad) B.
pub fn magnetic_dipole_force(m: &Vector3<f64>, grad_h: &Matrix3<f64>) -> Vector3<f64> {
    (grad_h * m) * MU0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mie_defaults() {
        let mie = Mie::new(30, 15, 1.0, 2.0).unwrap();
        assert!((mie.prefactor() - 4.0).abs() < 1e-15);
        assert!((mie.energy_unshifted(mie.r_min()) + 1.0).abs() < 1e-14);
        assert!(mie.energy(2.0 * mie.r_min()) == 0.0);
        assert!((mie.energy(2.0) - 1.0).abs() < 1e-15);
        assert!(mie.force_magnitude(1.9) > 0.0);
        assert!(Mie::new(6, 12, 1.0, 1.0).is_err());
    }

    #[test]
    fn dipole_head_to_tail() {
        let m = Vector3::new(0.0, 0.0, 1e-16);
        let r = Vector3::new(0.0, 0.0, 1e-6);
        let f = dipole_force(&r, &m, &m);
        let expect = -6.0 * MU0 * 1e-32 / (4.0 * PI * 1e-24);
        assert!((f.z - expect).abs() < 1e-14 * expect.abs());
        assert!(f.x == 0.0 && f.y == 0.0);
        let u = dipole_energy(&r, &m, &m);
        assert!((u + MU0 * 1e-32 / (2.0 * PI * 1e-18)).abs() < 1e-14 * u.abs());
    }

    #[test]
    fn langevin_limits() {
        assert_eq!(langevin(0.0), 0.0);
        assert!((langevin(1e-300) / 1e-300 - 1.0 / 3.0).abs() < 1e-16);
        assert!((langevin(-3.0) + langevin(3.0)).abs() == 0.0);
        assert_eq!(langevin(f64::INFINITY), 1.0);
        // continuity across the branch points
        for &x in &[1e-5, 2.0] {
            let a = langevin(x * (1.0 - 1e-15));
            let b = langevin(x * (1.0 + 1e-15));
            assert!((a - b).abs() < 1e-14 * a, "{x}: {a} {b}");
        }
    }

    #[test]
    fn moment_law() {
        let law = LangevinMoment::langevin(2e-16, 1e-19).unwrap();
        assert_eq!(law.moment(&Vector3::zeros(), 4e-21), Vector3::zeros());
        let h = Vector3::new(1e9, 0.0, 0.0);
        assert!((law.moment(&h, 4e-21).x - 2e-16).abs() < 1e-3 * 2e-16);
        assert_eq!(law.magnitude(1.0, 0.0), 2e-16);
    }
}
