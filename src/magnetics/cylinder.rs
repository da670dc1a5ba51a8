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
        let t = if near_axis(&self.geometry, p.x.hypot(p.y), p.z) {
            near_axis_tensor(&self.geometry, p.x, p.y, p.z)
        } else {
            tensor_with_gradient(&self.geometry, p.x, p.y, p.z)
        };
        Matrix3::from_fn(|i, j| (0..3).map(|k| t[i][k].d[j] * m[k]).sum())
    }
}
