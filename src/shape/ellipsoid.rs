//! Triaxial ellipsoid with semi-axes (a, b, c) along the body x, y, z axes (thesis eq. 4.1).
//!
//! V = 4/3 pi a b c; at unit density Ixx = V (b^2 + c^2)/5 (cyclic); bounding radius max(a, b, c).
//! The implicit function is (x/a)^2 + (y/b)^2 + (z/c)^2 - 1; the support point along d is
//! A^2 d / |A d| with A = diag(a, b, c).

use super::{area_weighted_samples, check_length, ConvexShape};
use crate::error::Result;
use nalgebra::Vector3;

/// A triaxial ellipsoid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipsoid {
    a: Vector3<f64>,
}

impl Ellipsoid {
    /// Semi-axes along x, y, z (each positive and finite).
    pub fn new(semi_axes: [f64; 3]) -> Result<Ellipsoid> {
        for (k, &v) in semi_axes.iter().enumerate() {
            check_length(&format!("ellipsoid semi-axis {}", ["a", "b", "c"][k]), v)?;
        }
        Ok(Ellipsoid {
            a: Vector3::from(semi_axes),
        })
    }

    /// The semi-axes (a, b, c).
    pub fn semi_axes(&self) -> [f64; 3] {
        [self.a.x, self.a.y, self.a.z]
    }
}

impl ConvexShape for Ellipsoid {
    fn volume(&self) -> f64 {
        4.0 / 3.0 * std::f64::consts::PI * self.a.x * self.a.y * self.a.z
    }

    fn principal_inertia_unit_density(&self) -> Vector3<f64> {
        let s = self.a.component_mul(&self.a);
        let v5 = self.volume() / 5.0;
        Vector3::new(v5 * (s.y + s.z), v5 * (s.x + s.z), v5 * (s.x + s.y))
    }

    fn bounding_radius(&self) -> f64 {
        self.a.max()
    }

    /// (x/a)^2 + (y/b)^2 + (z/c)^2 - 1.
    fn implicit(&self, p: &Vector3<f64>) -> f64 {
        p.component_div(&self.a).norm_squared() - 1.0
    }

    /// Normalised (x/a^2, y/b^2, z/c^2) (+z at the centre).
    fn normal(&self, p: &Vector3<f64>) -> Vector3<f64> {
        let g = p.component_div(&self.a).component_div(&self.a);
        let n = g.norm();
        if n > 0.0 && n.is_finite() {
            g / n
        } else {
            Vector3::z()
        }
    }

    /// A^2 d / |A d| (the +z pole for d = 0).
    fn support(&self, d: &Vector3<f64>) -> Vector3<f64> {
        let m = d.amax();
        if !m.is_finite() || m <= 0.0 {
            return Vector3::new(0.0, 0.0, self.a.z);
        }
        let ad = self.a.component_mul(&(d / m));
        self.a.component_mul(&ad) / ad.norm()
    }

    fn surface_samples(&self, n: usize) -> Vec<Vector3<f64>> {
        area_weighted_samples(
            n,
            self.a,
            |v| 1.0 / v.component_div(&self.a).norm(),
            |p| self.normal(p),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn sphere_case() {
        let e = Ellipsoid::new([2.0, 2.0, 2.0]).unwrap();
        assert!((e.volume() - 32.0 * PI / 3.0).abs() < 1e-14 * e.volume());
        let i = e.principal_inertia_unit_density();
        assert!((i.x - 0.4 * e.volume() * 4.0).abs() < 1e-14 * i.x);
        assert_eq!(e.bounding_radius(), 2.0);
    }

    #[test]
    fn support_and_normal() {
        let e = Ellipsoid::new([3.0, 1.0, 0.5]).unwrap();
        for d in [
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.3, -2.0, 1.0),
            Vector3::new(-1e-300, 1e-300, 0.0),
        ] {
            let p = e.support(&d);
            assert!(e.implicit(&p).abs() < 1e-14, "{p:?}");
            assert!((e.normal(&p) - (d / d.amax()).normalize()).norm() < 1e-14);
        }
        let pts = e.surface_samples(500);
        assert_eq!(pts.len(), 500);
        assert!(pts.iter().all(|p| e.implicit(p).abs() < 1e-14));
    }

    #[test]
    fn bad_axis() {
        let e = Ellipsoid::new([1.0, -2.0, 1.0]).unwrap_err().to_string();
        assert!(e.contains("semi-axis b = -2"), "{e}");
    }
}
