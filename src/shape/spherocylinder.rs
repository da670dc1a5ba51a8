//! Spherocylinder (thesis 003 section 2.2.2): the points within distance R of the segment
//! from (0, 0, -L/2) to (0, 0, L/2) (cylinder length L between the hemisphere centres, body
//! axis z). Aspect ratio (eq. 2.1) Lambda = (L + 2R) / (2R).
//!
//! Volume (eq. 2.2): V = pi R^2 (4/3 R + L).
//! Principal inertia (eq. 2.3, with m = V at unit density):
//!   Ixx = Iyy = m (5L^3 + 20L^2 R + 45 L R^2 + 32 R^3) / (20 (3L + 4R)),
//!   Izz = m (15 L R^2 + 16 R^3) / (10 (3L + 4R)).
//! (Validation case 003 checks these against a separately derived cylinder + two hemispheres
//! decomposition with the parallel-axis theorem, and against quadrature over z-slices.)
//! The implicit function is the signed distance dist(p, segment) - R.

use super::{area_weighted_samples, check_length, ConvexShape};
use crate::error::{invalid, Result};
use nalgebra::Vector3;
use std::f64::consts::PI;

/// A spherocylinder along the body z axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spherocylinder {
    radius: f64,
    length: f64,
}

impl Spherocylinder {
    /// Radius R > 0 and cylinder length L >= 0 (L = 0 is a sphere), both finite.
    pub fn new(radius: f64, length: f64) -> Result<Spherocylinder> {
        check_length("spherocylinder radius", radius)?;
        if !(length.is_finite() && length >= 0.0) {
            return invalid(format!(
                "spherocylinder length = {length}: must be non-negative and finite"
            ));
        }
        Ok(Spherocylinder { radius, length })
    }

    /// The radius R.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// The cylinder length L (distance between the hemisphere centres).
    pub fn length(&self) -> f64 {
        self.length
    }

    /// Aspect ratio (L + 2R) / (2R) (eq. 2.1).
    pub fn aspect_ratio(&self) -> f64 {
        (self.length + 2.0 * self.radius) / (2.0 * self.radius)
    }

    /// The point of the axis segment closest to p.
    fn closest_on_axis(&self, p: &Vector3<f64>) -> Vector3<f64> {
        let h = 0.5 * self.length;
        Vector3::new(0.0, 0.0, p.z.clamp(-h, h))
    }

    /// Distance from the centre to the surface along the unit direction v.
    fn radial(&self, v: &Vector3<f64>) -> f64 {
        let (r, h) = (self.radius, 0.5 * self.length);
        let rho = v.x.hypot(v.y);
        if rho * h <= r * v.z.abs() {
            // Beyond the cylinder part: hit the hemisphere centred at c = sign(vz) h e_z,
            // larger root of t^2 - 2 t (v.c) + h^2 - r^2 = 0.
            let vc = v.z.abs() * h;
            vc + (vc * vc - h * h + r * r).max(0.0).sqrt()
        } else {
            r / rho
        }
    }
}

impl ConvexShape for Spherocylinder {
    fn volume(&self) -> f64 {
        let (r, l) = (self.radius, self.length);
        PI * r * r * (4.0 / 3.0 * r + l)
    }

    fn principal_inertia_unit_density(&self) -> Vector3<f64> {
        let (r, l) = (self.radius, self.length);
        let m = self.volume();
        let d = 3.0 * l + 4.0 * r;
        let ixy = m / 20.0
            * (5.0 * l.powi(3) + 20.0 * l * l * r + 45.0 * l * r * r + 32.0 * r.powi(3))
            / d;
        let iz = m / 10.0 * (15.0 * l * r * r + 16.0 * r.powi(3)) / d;
        Vector3::new(ixy, ixy, iz)
    }

    fn bounding_radius(&self) -> f64 {
        0.5 * self.length + self.radius
    }

    /// Signed distance to the surface: dist(p, axis segment) - R.
    fn implicit(&self, p: &Vector3<f64>) -> f64 {
        (p - self.closest_on_axis(p)).norm() - self.radius
    }

    /// Unit vector from the closest axis point to p (+x on the axis segment itself).
    fn normal(&self, p: &Vector3<f64>) -> Vector3<f64> {
        let d = p - self.closest_on_axis(p);
        let n = d.norm();
        if n > 0.0 {
            d / n
        } else {
            Vector3::x()
        }
    }

    /// R d/|d| + sign(d_z) L/2 e_z (the cylinder's midline point z = 0 for d_z = 0; the +z tip
    /// for d = 0).
    fn support(&self, d: &Vector3<f64>) -> Vector3<f64> {
        let n = d.norm();
        let u = if n > 0.0 { d / n } else { Vector3::z() };
        let z = if u.z > 0.0 {
            0.5 * self.length
        } else if u.z < 0.0 {
            -0.5 * self.length
        } else {
            0.0
        };
        u * self.radius + Vector3::new(0.0, 0.0, z)
    }

    fn surface_samples(&self, n: usize) -> Vec<Vector3<f64>> {
        let r = self.radius;
        area_weighted_samples(
            n,
            Vector3::new(r, r, r + 0.5 * self.length),
            |v| self.radial(v),
            |p| self.normal(p),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_limit_and_formulas() {
        let s = Spherocylinder::new(1.5, 0.0).unwrap();
        let v = 4.0 / 3.0 * PI * 1.5f64.powi(3);
        assert!((s.volume() - v).abs() < 1e-14 * v);
        let i = s.principal_inertia_unit_density();
        for k in 0..3 {
            assert!((i[k] - 0.4 * v * 2.25).abs() < 1e-14 * i[k]);
        }
        let s = Spherocylinder::new(0.5, 3.0).unwrap();
        assert_eq!(s.bounding_radius(), 2.0);
        assert!((s.aspect_ratio() - 4.0).abs() < 1e-15);
        let m = 7.0;
        let im = s.principal_inertia(m);
        let iu = s.principal_inertia_unit_density();
        assert!((im.x - iu.x * m / s.volume()).abs() < 1e-14 * im.x);
    }

    #[test]
    fn surface_queries() {
        let s = Spherocylinder::new(0.5, 3.0).unwrap();
        let p = s.support(&Vector3::new(0.0, 0.0, 1.0));
        assert!((p - Vector3::new(0.0, 0.0, 2.0)).norm() < 1e-15);
        let d = Vector3::new(1.0, 2.0, -0.3);
        let p = s.support(&d);
        assert!(s.implicit(&p).abs() < 1e-15);
        assert!((s.normal(&p) - d.normalize()).norm() < 1e-14);
        let pts = s.surface_samples(2000);
        assert_eq!(pts.len(), 2000);
        // Area fractions: cylinder 2 pi R L, caps 4 pi R^2.
        let on_cyl = pts.iter().filter(|p| p.z.abs() < 1.5).count() as f64 / 2000.0;
        let frac = 3.0 / (3.0 + 2.0 * 0.5);
        assert!((on_cyl - frac).abs() < 0.01, "{on_cyl} vs {frac}");
        for q in &pts {
            assert!(s.implicit(q).abs() < 1e-14);
        }
    }

    #[test]
    fn bad_input() {
        assert!(Spherocylinder::new(0.0, 1.0).is_err());
        let e = Spherocylinder::new(1.0, -1.0).unwrap_err().to_string();
        assert!(
            e.contains("length = -1") && e.contains("non-negative"),
            "{e}"
        );
    }
}
