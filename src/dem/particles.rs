//! The spheres' dynamic state: centres, velocities, spins, radii and masses (SI), structure of
//! arrays; a [`crate::dem::Start`] gives them at t = 0 and a [`crate::dem::Dem`] advances them.

use nalgebra::Vector3;
use std::f64::consts::PI;

/// Sphere states (SI), structure of arrays.
#[derive(Debug, Clone, Default)]
pub struct Particles {
    pub pos: Vec<Vector3<f64>>,
    pub vel: Vec<Vector3<f64>>,
    pub omega: Vec<Vector3<f64>>,
    pub radius: Vec<f64>,
    pub mass: Vec<f64>,
}

impl Particles {
    /// Spheres at rest of the given centres and radii, density `rho`.
    pub fn at_rest(pos: Vec<Vector3<f64>>, radius: Vec<f64>, rho: f64) -> Particles {
        let n = pos.len();
        let mass = radius
            .iter()
            .map(|r| rho * 4.0 / 3.0 * PI * r.powi(3))
            .collect();
        Particles {
            pos,
            vel: vec![Vector3::zeros(); n],
            omega: vec![Vector3::zeros(); n],
            radius,
            mass,
        }
    }
    pub fn len(&self) -> usize {
        self.pos.len()
    }
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }
}
