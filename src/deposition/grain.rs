//! One pigment particle of the deposition model: an ellipsoid with its fixed properties
//! (volume, the inertia ratios of eq. A14-A15, the principal drag resistances of eq. A11,
//! buoyant weight) and its pose.

use crate::error::{invalid, Result};
use crate::hydro::happel_brenner::principal_resistances;
use nalgebra::{UnitQuaternion, Vector3};

/// The fixed properties of one particle (all SI).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grain {
    /// Semi-axes (a, b, c) along the body x, y, z axes, m.
    pub semi_axes: [f64; 3],
    /// Index of the species in the scene.
    pub species: usize,
    /// Volume 4/3 pi a b c, m^3.
    pub volume_m3: f64,
    /// I_a / v, I_b / v, I_c / v (eq. A15: I_a / v = (b^2 + c^2) / 5), m^2.
    pub inertia_per_volume_m2: [f64; 3],
    /// Principal translational resistances per unit viscosity C_a, C_b, C_c (eq. A11), m.
    pub drag_m: [f64; 3],
    /// Buoyant weight (rho_p - rho_f) v g, N.
    pub buoyant_weight_n: f64,
    /// Largest semi-axis (bounding sphere radius), m.
    pub outer_radius_m: f64,
    /// Smallest semi-axis (inscribed sphere radius), m.
    pub inner_radius_m: f64,
    /// All three semi-axes equal: no rotation, closed-form overlap.
    pub is_sphere: bool,
}

impl Grain {
    /// A grain of the given semi-axes (m), particle density and fluid density (kg/m^3) under
    /// gravity g (m/s^2).
    pub fn new(
        semi_axes: [f64; 3],
        species: usize,
        density_kg_m3: f64,
        fluid_density_kg_m3: f64,
        gravity_m_s2: f64,
    ) -> Result<Grain> {
        for (k, &s) in semi_axes.iter().enumerate() {
            if !(s.is_finite() && s > 0.0) {
                return invalid(format!(
                    "semi-axis {} = {s} m: must be positive and finite",
                    ["a", "b", "c"][k]
                ));
            }
        }
        let [a, b, c] = semi_axes;
        let volume_m3 = 4.0 / 3.0 * std::f64::consts::PI * a * b * c;
        // Per unit viscosity: the hydro kernel takes mu and returns C mu; mu = 1 gives C.
        let drag_m = principal_resistances(semi_axes, 1.0)?;
        let outer = a.max(b).max(c);
        let inner = a.min(b).min(c);
        Ok(Grain {
            semi_axes,
            species,
            volume_m3,
            inertia_per_volume_m2: [
                (b * b + c * c) / 5.0,
                (a * a + c * c) / 5.0,
                (a * a + b * b) / 5.0,
            ],
            drag_m,
            buoyant_weight_n: (density_kg_m3 - fluid_density_kg_m3) * volume_m3 * gravity_m_s2,
            outer_radius_m: outer,
            inner_radius_m: inner,
            is_sphere: outer == inner,
        })
    }

    /// Half the vertical extent of the posed ellipsoid, sqrt(sum_i (a_i R_zi)^2): the centre
    /// height at which it touches a horizontal plane (its support along z).
    pub fn half_height(&self, orientation: &UnitQuaternion<f64>) -> f64 {
        if self.is_sphere {
            return self.semi_axes[0];
        }
        let r = vertical_row(orientation);
        let [a, b, c] = self.semi_axes;
        ((a * r[0]).powi(2) + (b * r[1]).powi(2) + (c * r[2]).powi(2)).sqrt()
    }

    /// The zz component of the posed resistance tensor per unit viscosity, m (eq. A3 with the
    /// flow along z: C = sum_i C_i (z . e_i)^2).
    pub fn drag_zz(&self, orientation: &UnitQuaternion<f64>) -> f64 {
        if self.is_sphere {
            return self.drag_m[0];
        }
        let r = vertical_row(orientation);
        self.drag_m[0] * r[0] * r[0] + self.drag_m[1] * r[1] * r[1] + self.drag_m[2] * r[2] * r[2]
    }

    /// The longest semi-axis' diameter, m.
    pub fn longest_diameter(&self) -> f64 {
        2.0 * self.outer_radius_m
    }
}

/// z components of the body axes in the world frame (the third row of the rotation matrix).
pub fn vertical_row(q: &UnitQuaternion<f64>) -> [f64; 3] {
    let (w, x, y, z) = (q.w, q.i, q.j, q.k);
    [
        2.0 * (x * z - w * y),
        2.0 * (y * z + w * x),
        1.0 - 2.0 * (x * x + y * y),
    ]
}

/// Position and orientation (body -> world) of one particle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrainPose {
    pub position: Vector3<f64>,
    pub orientation: UnitQuaternion<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertical_row_is_the_third_row_of_the_rotation_matrix() {
        let q = UnitQuaternion::from_euler_angles(0.3, -1.1, 2.0);
        let m = q.to_rotation_matrix().into_inner();
        let r = vertical_row(&q);
        for i in 0..3 {
            assert!((r[i] - m[(2, i)]).abs() < 1e-15);
        }
    }

    #[test]
    fn sphere_drag_is_stokes_and_half_height_the_radius() {
        let g = Grain::new([1e-6; 3], 0, 2500.0, 1000.0, 9.81).unwrap();
        assert!(g.is_sphere);
        let c = 6.0 * std::f64::consts::PI * 1e-6;
        assert!((g.drag_m[0] - c).abs() < 1e-13 * c);
        assert_eq!(g.half_height(&UnitQuaternion::identity()), 1e-6);
    }
}
