//! Translational resistance of a triaxial ellipsoid in Stokes flow (Oberbeck 1876; Happel &
//! Brenner 1965, section 5-11), as used by the deposition model of seed 000 (appendix A,
//! eq. A3-A11).
//!
//! For semi-axes (a, b, c) and motion along the a axis, F = C_a U with
//!   C_a = 16 pi mu / (chi + a^2 psi_a),  chi = int_0^inf dl / Delta,
//!   psi_a = int_0^inf dl / ((a^2 + l) Delta),  Delta = sqrt((a^2 + l)(b^2 + l)(c^2 + l))
//! (seed eq. A4-A8 write C_a = 6 pi R_a with R_a = 8 / (3 (chi + psi_a a^2)): the same thing;
//! the seed's C is per unit viscosity, C mu V in eq. A2). With Carlson's symmetric integrals,
//! R_F(x, y, z) = 1/2 int_0^inf dt / sqrt((t+x)(t+y)(t+z)) and
//! R_D(x, y, z) = 3/2 int_0^inf dt / ((t+z) sqrt((t+x)(t+y)(t+z))) (DLMF 19.16.1, 19.16.5),
//! chi = 2 R_F(a^2, b^2, c^2) and psi_a = 2/3 R_D(b^2, c^2, a^2) (eq. A9-A10; the seed writes
//! R_D(c^2, b^2, a^2), equal because R_D is symmetric in its first two arguments), so
//!   C_a = 8 pi mu / (R_F(a^2, b^2, c^2) + a^2/3 R_D(b^2, c^2, a^2))   (eq. A11 times mu).
//! Prefactor check: a sphere (R_F = 1/a, R_D = 1/a^3) gives 8 pi mu / (4/(3a)) = 6 pi mu a, so
//! the seed's eq. A11 is right as printed.
//!
//! The axes are scaled by the largest before the Carlson integrals (C is homogeneous of degree
//! 1 in the lengths), so extreme sizes neither overflow nor underflow.
//!
//! In a rotated frame the resistance tensor is R diag(C_a, C_b, C_c) R^T (R maps body axes to
//! world axes; eq. A3 is z . (this tensor) z for the vertical direction z). The
//! orientation-averaged ("mobility-averaged") resistance is the inverse of the average
//! mobility, f = 3 / (1/C_a + 1/C_b + 1/C_c).

use super::check_viscosity;
use crate::error::{invalid, Result};
use crate::special::elliptic::{carlson_rd, carlson_rf};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

fn check_axes(semi_axes: &[f64; 3]) -> Result<()> {
    for (k, &v) in semi_axes.iter().enumerate() {
        if !(v.is_finite() && v > 0.0) {
            return invalid(format!(
                "semi-axis {} = {v} m: must be positive and finite",
                ["a", "b", "c"][k]
            ));
        }
    }
    Ok(())
}

/// Principal translational resistances (C_a, C_b, C_c) in N s/m for motion along each
/// semi-axis (m) in a fluid of viscosity mu (Pa s) (eq. A11 times mu).
pub fn principal_resistances(semi_axes: [f64; 3], viscosity: f64) -> Result<[f64; 3]> {
    check_viscosity(viscosity)?;
    check_axes(&semi_axes)?;
    let s = semi_axes.iter().cloned().fold(0.0, f64::max);
    // eq. A11 takes R_F and R_D of the squared axis ratios; a ratio below sqrt(MIN_POSITIVE)
    // squares to a subnormal or 0, where Carlson's integrals are undefined or lose all digits.
    let smallest = semi_axes.iter().cloned().fold(f64::INFINITY, f64::min);
    let min_ratio = f64::MIN_POSITIVE.sqrt();
    if smallest / s < min_ratio {
        return invalid(format!(
            "semi-axes ({:e}, {:e}, {:e}) m: smallest / largest = {:e} must be at least {min_ratio:.3e} \
             (the squared axis ratios of seed 000 eq. A11 must be normal f64 numbers)",
            semi_axes[0],
            semi_axes[1],
            semi_axes[2],
            smallest / s
        ));
    }
    let q = semi_axes.map(|x| (x / s) * (x / s));
    let rf = carlson_rf(q[0], q[1], q[2])?;
    let mut out = [0.0; 3];
    for i in 0..3 {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        let rd = carlson_rd(q[j], q[k], q[i])?;
        out[i] = 8.0 * std::f64::consts::PI * viscosity * s / (rf + q[i] / 3.0 * rd);
    }
    Ok(out)
}

/// Resistance tensor in the world frame, R diag(C) R^T, for a body whose axes are rotated by
/// `orientation` (body -> world).
pub fn resistance_tensor(
    semi_axes: [f64; 3],
    viscosity: f64,
    orientation: &UnitQuaternion<f64>,
) -> Result<Matrix3<f64>> {
    let c = principal_resistances(semi_axes, viscosity)?;
    Ok(tensor_from_principal(&c, orientation))
}

fn tensor_from_principal(c: &[f64; 3], orientation: &UnitQuaternion<f64>) -> Matrix3<f64> {
    let r = orientation.to_rotation_matrix().into_inner();
    r * Matrix3::from_diagonal(&Vector3::from(*c)) * r.transpose()
}

/// Orientation-averaged resistance 3 / (1/C_a + 1/C_b + 1/C_c) in N s/m.
pub fn mobility_averaged_resistance(semi_axes: [f64; 3], viscosity: f64) -> Result<f64> {
    let c = principal_resistances(semi_axes, viscosity)?;
    Ok(harmonic3(&c))
}

fn harmonic3(c: &[f64; 3]) -> f64 {
    3.0 / (1.0 / c[0] + 1.0 / c[1] + 1.0 / c[2])
}

/// The principal resistances of one ellipsoid, computed once (seed 000: "need only to be
/// computed once and for all").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EllipsoidDrag {
    /// C_a, C_b, C_c in N s/m.
    pub principal: [f64; 3],
}

impl EllipsoidDrag {
    pub fn new(semi_axes: [f64; 3], viscosity: f64) -> Result<EllipsoidDrag> {
        Ok(EllipsoidDrag {
            principal: principal_resistances(semi_axes, viscosity)?,
        })
    }

    /// World-frame resistance tensor for the given orientation (body -> world).
    pub fn tensor(&self, orientation: &UnitQuaternion<f64>) -> Matrix3<f64> {
        tensor_from_principal(&self.principal, orientation)
    }

    /// Resistance along the world unit direction u, u . T u (eq. A3 with u = z).
    pub fn along(&self, orientation: &UnitQuaternion<f64>, u: &Vector3<f64>) -> f64 {
        let b = orientation.inverse_transform_vector(u);
        (0..3).map(|i| self.principal[i] * b[i] * b[i]).sum()
    }

    /// 3 / sum(1/C_i).
    pub fn mobility_averaged(&self) -> f64 {
        harmonic3(&self.principal)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn sphere_is_stokes() {
        for a in [1e-9, 1e-3, 1.0, 7.5e4] {
            let c = principal_resistances([a, a, a], 2e-3).unwrap();
            for ci in c {
                assert!((ci - 6.0 * PI * 2e-3 * a).abs() <= 4e-16 * ci, "{ci}");
            }
        }
    }

    #[test]
    fn symmetry_and_tensor() {
        let c = principal_resistances([3.0, 1.0, 1.0], 1.0).unwrap();
        assert!((c[1] - c[2]).abs() < 1e-15 * c[1]);
        assert!(c[0] < c[1], "end-on moves more easily: {c:?}");
        let c2 = principal_resistances([1.0, 3.0, 1.0], 1.0).unwrap();
        assert!((c2[1] - c[0]).abs() < 1e-15 * c[0]);
        let q = UnitQuaternion::from_euler_angles(0.3, -1.1, 2.0);
        let t = resistance_tensor([3.0, 1.0, 0.5], 1.0, &q).unwrap();
        assert!((t - t.transpose()).norm() < 1e-14 * t.norm());
        let d = EllipsoidDrag::new([3.0, 1.0, 0.5], 1.0).unwrap();
        assert!((t.trace() - d.principal.iter().sum::<f64>()).abs() < 1e-13 * t.trace());
        let u = Vector3::new(0.0, 0.0, 1.0);
        assert!((d.along(&q, &u) - (u.transpose() * t * u)[0]).abs() < 1e-13 * t.trace());
        let f = mobility_averaged_resistance([3.0, 1.0, 0.5], 1.0).unwrap();
        assert!((f - d.mobility_averaged()).abs() == 0.0);
    }

    #[test]
    fn disk_limits() {
        let c = principal_resistances([1.0, 1.0, 1e-14], 1.0).unwrap();
        assert!((c[2] - 16.0).abs() < 1e-13 * 16.0, "{c:?}");
        assert!((c[0] - 32.0 / 3.0).abs() < 1e-13 * 11.0, "{c:?}");
    }

    #[test]
    fn bad_input() {
        let e = principal_resistances([1.0, 0.0, 1.0], 1.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("semi-axis b = 0"), "{e}");
        let e = principal_resistances([1.0, 1.0, 1.0], -1.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("viscosity = -1"), "{e}");
    }
}
