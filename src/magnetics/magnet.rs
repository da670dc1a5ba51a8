//! Posed cylinders and sums of them (thesis section 5.6).

use super::Cylinder;
use crate::error::{invalid, Result};
use nalgebra::{Matrix3, Rotation3, Unit, Vector3};

/// A uniformly magnetized cylinder placed in the world: centre (m), axis direction (unit), and
/// magnetization M (A/m) in world coordinates.
#[derive(Debug, Clone)]
pub struct Magnet {
    pub cylinder: Cylinder,
    pub centre: Vector3<f64>,
    /// Rotation taking cylinder-frame vectors to world vectors (its z axis is the cylinder axis).
    rotation: Rotation3<f64>,
    pub magnetization: Vector3<f64>,
}

impl Magnet {
    /// `axis` need not be unit length but must be finite and non-zero.
    pub fn new(
        cylinder: Cylinder,
        centre: Vector3<f64>,
        axis: Vector3<f64>,
        magnetization: Vector3<f64>,
    ) -> Result<Magnet> {
        if !centre.iter().all(|v| v.is_finite()) {
            return invalid(format!("magnet centre {centre:?} must be finite"));
        }
        if !magnetization.iter().all(|v| v.is_finite()) {
            return invalid(format!(
                "magnetization {magnetization:?} A/m must be finite"
            ));
        }
        let n = axis.norm();
        if !(n.is_finite() && n > 0.0) {
            return invalid(format!(
                "cylinder axis {axis:?} must be finite and non-zero"
            ));
        }
        let axis = Unit::new_unchecked(axis / n);
        let rotation = Rotation3::rotation_between(&Vector3::z(), &axis).unwrap_or_else(|| {
            Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
        });
        Ok(Magnet {
            cylinder,
            centre,
            rotation,
            magnetization,
        })
    }
    pub fn axis(&self) -> Vector3<f64> {
        self.rotation * Vector3::z()
    }
    fn to_local(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rotation.inverse() * (p - self.centre)
    }
    /// H (A/m) at world point p (m).
    pub fn h_field(&self, p: &Vector3<f64>) -> Vector3<f64> {
        let m_local = self.rotation.inverse() * self.magnetization;
        self.rotation * self.cylinder.h_field(&m_local, &self.to_local(p))
    }
    /// B (T) at world point p (m); surface points count as outside.
    pub fn b_field(&self, p: &Vector3<f64>) -> Vector3<f64> {
        let m_local = self.rotation.inverse() * self.magnetization;
        self.rotation * self.cylinder.b_field(&m_local, &self.to_local(p))
    }
    /// B (T) at world point p given H (A/m) there: mu0 (H + M) strictly inside, mu0 H elsewhere.
    pub fn b_from_h(&self, p: &Vector3<f64>, h: &Vector3<f64>) -> Vector3<f64> {
        let inside = self.cylinder.contains(&self.to_local(p));
        (h + if inside {
            self.magnetization
        } else {
            Vector3::zeros()
        }) * crate::consts::MU0
    }
    /// dH_i/dx_j (A/m^2) at world point p.
    pub fn h_gradient(&self, p: &Vector3<f64>) -> Matrix3<f64> {
        self.h_and_gradient(p).1
    }
    /// (H in A/m, dH_i/dx_j in A/m^2) at world point p from one kernel evaluation.
    pub fn h_and_gradient(&self, p: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        let m_local = self.rotation.inverse() * self.magnetization;
        let (h, g) = self.cylinder.h_and_gradient(&m_local, &self.to_local(p));
        let r = self.rotation.matrix();
        (r * h, r * g * r.transpose())
    }
}

/// A set of magnets whose fields superpose (mutual magnetization is not iterated).
#[derive(Debug, Clone, Default)]
pub struct Assembly {
    pub magnets: Vec<Magnet>,
}

impl Assembly {
    pub fn h_field(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.magnets.iter().map(|m| m.h_field(p)).sum()
    }
    pub fn b_field(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.magnets.iter().map(|m| m.b_field(p)).sum()
    }
    pub fn h_gradient(&self, p: &Vector3<f64>) -> Matrix3<f64> {
        self.magnets.iter().map(|m| m.h_gradient(p)).sum()
    }
    pub fn h_and_gradient(&self, p: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        self.magnets
            .iter()
            .map(|m| m.h_and_gradient(p))
            .fold((Vector3::zeros(), Matrix3::zeros()), |(h, g), (hm, gm)| {
                (h + hm, g + gm)
            })
    }
}
