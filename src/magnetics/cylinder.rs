//! Field of one uniformly magnetized cylinder in its own frame.

use super::kernel::{
    field_h, field_tensor, near_axis, near_axis_tensor, radial_gap, tensor_with_gradient,
    KernelGeometry, Regime,
};
use crate::error::{invalid, Result};
use nalgebra::{Matrix3, Vector3};

/// A solid circular cylinder of radius R and semi-length L (metres), centred at the origin
/// with its axis along z: rho <= R, |z| <= L.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cylinder {
    radius_m: f64,
    half_length_m: f64,
    geometry: KernelGeometry,
}

impl Cylinder {
    /// R and L must be positive and finite.
    pub fn new(radius_m: f64, half_length_m: f64) -> Result<Cylinder> {
        if !(radius_m.is_finite() && radius_m > 0.0) {
            return invalid(format!(
                "cylinder radius {radius_m} m must be positive and finite"
            ));
        }
        if !(half_length_m.is_finite() && half_length_m > 0.0) {
            return invalid(format!(
                "cylinder half-length {half_length_m} m must be positive and finite"
            ));
        }
        Ok(Cylinder {
            radius_m,
            half_length_m,
            geometry: KernelGeometry::new(radius_m, half_length_m),
        })
    }
    pub fn radius_m(&self) -> f64 {
        self.radius_m
    }
    pub fn half_length_m(&self) -> f64 {
        self.half_length_m
    }
    /// True strictly inside (rho < R and |z| < L); points on the surface count as outside.
    pub fn contains(&self, p: &Vector3<f64>) -> bool {
        // The same exact test the kernel uses (R - rho in compensated arithmetic).
        radial_gap(self.radius_m, p.x, p.y) > 0.0 && p.z.abs() < self.half_length_m
    }
    /// Demagnetization-type tensor T(p) with H = T M (A/m per A/m), T = Hess psi where
    /// psi(p) = (1/4 pi) int_cyl dV'/|p - p'|. Symmetric; trace -1 inside, 0 outside.
    ///
    /// Points exactly on the surface get the limit from outside; on the two rim circles
    /// (rho = R, |z| = L) the field is logarithmically infinite and the entries are infinite.
    pub fn field_tensor(&self, p: &Vector3<f64>) -> Matrix3<f64> {
        self.field_tensor_with_regime(p).0
    }
    /// As [`Cylinder::field_tensor`], also naming the formula used (for diagnostics).
    pub fn field_tensor_with_regime(&self, p: &Vector3<f64>) -> (Matrix3<f64>, Regime) {
        let (t, regime) = field_tensor(&self.geometry, p.x, p.y, p.z);
        (Matrix3::from_fn(|i, j| t[i][j]), regime)
    }
    /// H in A/m at p (m, cylinder frame) for magnetization m (A/m, cylinder frame).
    /// (A longitudinal m only needs the axial part of the tensor: see [`field_h`].)
    pub fn h_field(&self, m: &Vector3<f64>, p: &Vector3<f64>) -> Vector3<f64> {
        Vector3::from(field_h(&self.geometry, p.x, p.y, p.z, [m.x, m.y, m.z]))
    }
    /// B in T: mu0 (H + M) strictly inside, mu0 H elsewhere (surface = outside limit).
    pub fn b_field(&self, m: &Vector3<f64>, p: &Vector3<f64>) -> Vector3<f64> {
        let h = self.h_field(m, p);
        let inside = if self.contains(p) {
            *m
        } else {
            Vector3::zeros()
        };
        (h + inside) * crate::consts::MU0
    }
    /// Gradient G[(i, j)] = dH_i/dx_j in A/m^2 at p, for magnetization m.
    /// Exact to rounding: forward-mode automatic differentiation of the same formulas.
    /// Within 1e-3 (of R and of the distance to the cap planes) of the axis, where the
    /// closed forms' rho-odd pieces would lose digits in the derivative, the off-axis expansion
    /// of the potential is differentiated instead.
    pub fn h_gradient(&self, m: &Vector3<f64>, p: &Vector3<f64>) -> Matrix3<f64> {
        self.h_and_gradient(m, p).1
    }
    /// (H, dH_i/dx_j) at p from one evaluation: the value parts of the differentiated tensor
    /// give H, so a caller that needs both (the Brownian force, eq. 6.20) pays for one pass.
    pub fn h_and_gradient(
        &self,
        m: &Vector3<f64>,
        p: &Vector3<f64>,
    ) -> (Vector3<f64>, Matrix3<f64>) {
        let t = if near_axis(&self.geometry, p.x.hypot(p.y), p.z) {
            near_axis_tensor(&self.geometry, p.x, p.y, p.z)
        } else {
            tensor_with_gradient(&self.geometry, p.x, p.y, p.z)
        };
        let h = Vector3::from_fn(|i, _| (0..3).map(|k| t[i][k].v * m[k]).sum());
        let g = Matrix3::from_fn(|i, j| (0..3).map(|k| t[i][k].d[j] * m[k]).sum());
        (h, g)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The H of the one-pass (H, gradient) evaluation is the H of `h_field` (to rounding:
    /// both evaluate the same formulas, one in dual numbers), over near-axis, near-surface and
    /// far points and several aspect ratios.
    #[test]
    fn one_pass_field_matches_h_field() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let m = Vector3::new(0.3e6, -0.2e6, 0.9e6);
        let mut worst = 0.0f64;
        for &(r, l) in &[(1.0, 1.0), (0.3e-3, 6e-3), (1.0, 1e-3), (1e-3, 1.0)] {
            let c = Cylinder::new(r, l).unwrap();
            for k in 0..3000 {
                let scale = [1e-6, 1e-2, 1.0, 10.0, 1e3][k % 5] * r.max(l);
                let p = Vector3::new(
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                ) * scale
                    + Vector3::new(0.0, 0.0, [0.0, l, 1.01 * l][k % 3]);
                let h = c.h_field(&m, &p);
                let (h1, _) = c.h_and_gradient(&m, &p);
                worst = worst.max((h1 - h).norm() / h.norm());
            }
        }
        assert!(worst < 1e-12, "worst relative difference {worst:e}");
    }

    /// The gradient exactly on the axis beyond r = 4a (the multipole regime, where rho = 0
    /// once gave 0/0) against the on-axis closed forms (thesis eq. 5.26-5.27, the solenoid
    /// formula): with S'(z) = R^2 [((z+L)^2 + R^2)^(-3/2) - ((z-L)^2 + R^2)^(-3/2)],
    /// longitudinal M: dHz/dz = M S'/2, dHx/dx = dHy/dy = -M S'/4 (div H = 0, axial symmetry);
    /// transverse M along x: dHx/dz = dHz/dx = -M S'/4; every other entry 0.
    #[test]
    fn gradient_on_the_axis_in_the_far_regime() {
        for &(r, l) in &[(1.0, 1.0), (0.3e-3, 0.5e-3), (1.0, 0.01)] {
            let c = Cylinder::new(r, l).unwrap();
            let a = r.hypot(l);
            for &z in &[5.0 * a, 30.0 * a, -7.0 * a] {
                let p = Vector3::new(0.0, 0.0, z);
                let s3 = |h: f64| r * r / (h * h + r * r).powf(1.5);
                let ds = s3(z + l) - s3(z - l);
                let m = 1e6;
                let (_, gl) = c.h_and_gradient(&Vector3::new(0.0, 0.0, m), &p);
                let (_, gt) = c.h_and_gradient(&Vector3::new(m, 0.0, 0.0), &p);
                let mut want_l = Matrix3::zeros();
                want_l[(2, 2)] = 0.5 * m * ds;
                want_l[(0, 0)] = -0.25 * m * ds;
                want_l[(1, 1)] = -0.25 * m * ds;
                let mut want_t = Matrix3::zeros();
                want_t[(0, 2)] = -0.25 * m * ds;
                want_t[(2, 0)] = -0.25 * m * ds;
                for (got, want) in [(gl, want_l), (gt, want_t)] {
                    assert!(
                        got.iter().all(|v| v.is_finite()),
                        "r={r} l={l} z={z}: {got}"
                    );
                    // S' is a difference of nearly equal terms far out: ~(z/L) eps relative.
                    let err = (got - want).norm() / want.norm();
                    assert!(err < 1e-10, "r={r} l={l} z={z}: {got} vs {want} ({err:e})");
                }
            }
        }
    }
}
