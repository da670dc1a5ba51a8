//! Sphere of radius R (body frame: centre at the origin).
//!
//! V = 4/3 pi R^3, I = 2/5 V R^2 about any axis at unit density. The implicit function is the
//! signed distance |p| - R.

use super::{check_length, fibonacci_directions, ConvexShape};
use crate::error::Result;
use nalgebra::Vector3;

/// A sphere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    radius: f64,
}

impl Sphere {
    /// A sphere of the given radius (positive and finite).
    pub fn new(radius: f64) -> Result<Sphere> {
        check_length("sphere radius", radius)?;
        Ok(Sphere { radius })
    }

    /// The radius.
    pub fn radius(&self) -> f64 {
        self.radius
    }
}

impl ConvexShape for Sphere {
    fn volume(&self) -> f64 {
        4.0 / 3.0 * std::f64::consts::PI * self.radius.powi(3)
    }

    fn principal_inertia_unit_density(&self) -> Vector3<f64> {
        let i = 0.4 * self.volume() * self.radius * self.radius;
        Vector3::new(i, i, i)
    }

    fn bounding_radius(&self) -> f64 {
        self.radius
    }

    /// Signed distance |p| - R.
    fn implicit(&self, p: &Vector3<f64>) -> f64 {
        p.norm() - self.radius
    }

    /// p / |p| (+z at the centre).
    fn normal(&self, p: &Vector3<f64>) -> Vector3<f64> {
        let n = p.norm();
        if n > 0.0 {
            p / n
        } else {
            Vector3::z()
        }
    }

    /// R d / |d| (the +z pole for d = 0).
    fn support(&self, d: &Vector3<f64>) -> Vector3<f64> {
        self.normal(d) * self.radius
    }

    /// A Fibonacci lattice (equal area per point).
    fn surface_samples(&self, n: usize) -> Vec<Vector3<f64>> {
        fibonacci_directions(n)
            .into_iter()
            .map(|u| u * self.radius)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn formulas() {
        let s = Sphere::new(2.0).unwrap();
        assert!((s.volume() - 32.0 * PI / 3.0).abs() < 1e-14 * s.volume());
        let i = s.principal_inertia_unit_density();
        assert!((i.x - 0.4 * s.volume() * 4.0).abs() < 1e-14 * i.x);
        assert_eq!(i.x, i.z);
        let im = s.principal_inertia(3.0);
        assert!((im.y - 0.4 * 3.0 * 4.0).abs() < 1e-14);
        assert_eq!(s.bounding_radius(), 2.0);
        let d = Vector3::new(1.0, -2.0, 0.5);
        let p = s.support(&d);
        assert!((p.norm() - 2.0).abs() < 1e-15 && (p.normalize() - d.normalize()).norm() < 1e-15);
        assert!(s.implicit(&p).abs() < 1e-15);
        for q in s.surface_samples(100) {
            assert!(s.implicit(&q).abs() < 1e-14);
        }
    }

    #[test]
    fn bad_radius() {
        for r in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = Sphere::new(r).unwrap_err().to_string();
            assert!(e.contains("radius") && e.contains("positive"), "{e}");
        }
    }
}
