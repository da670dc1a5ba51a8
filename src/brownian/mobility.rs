//! Translational mobility tensors of N identical spheres (thesis 003, section 6.2.2).
//!
//! The mobility M (m/(N s)) maps forces to velocities, V = M F; the diffusion tensor of
//! eq. 6.5–6.10 is D = kB T M. Working with M keeps the drift exact at kB T = 0. All three
//! tensors have zero divergence, so the Ermak–McCammon update needs no divergence term
//! (eq. 6.7 -> 6.11; for RPY this holds in both branches).

use crate::error::{invalid, Result};
use nalgebra::{DMatrix, Matrix3, Vector3};
use std::f64::consts::PI;

/// Which hydrodynamic interactions the mobility includes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Hydrodynamics {
    /// No hydrodynamic interactions: M = I / (6 pi eta a) (eq. 6.8).
    FreeDraining,
    /// Oseen tensor off the diagonal (eq. 6.9); singular at r = 0 and not positive definite
    /// for r < ~1.5 a.
    Oseen,
    /// Rotne–Prager–Yamakawa (eq. 6.10), both the r >= 2a and the overlapping r < 2a branch;
    /// positive definite for every configuration.
    Rpy,
}

impl Hydrodynamics {
    /// The name a scene file uses for it (`[hydrodynamics] mobility`).
    pub fn scene_name(self) -> &'static str {
        match self {
            Hydrodynamics::FreeDraining => "free-draining",
            Hydrodynamics::Oseen => "oseen",
            Hydrodynamics::Rpy => "rpy",
        }
    }
}

/// Stokes mobility 1 / (6 pi eta a) of one sphere (m/(N s)).
pub fn stokes_mobility(viscosity: f64, radius: f64) -> Result<f64> {
    if !(viscosity.is_finite() && viscosity > 0.0) {
        return invalid(format!(
            "viscosity = {viscosity} Pa s: must be positive and finite"
        ));
    }
    if !(radius.is_finite() && radius > 0.0) {
        return invalid(format!(
            "particle radius = {radius} m: must be positive and finite"
        ));
    }
    Ok(1.0 / (6.0 * PI * viscosity * radius))
}

/// RPY pair block in units of the Stokes mobility 1/(6 pi eta a), for the separation vector
/// `r` (m) of two spheres of radius `a` (eq. 6.10). The far branch is used for |r| >= 2a (the
/// two branches agree at 2a: 7/16 I + 3/16 r r^T / r^2).
pub fn rpy_pair(r: &Vector3<f64>, a: f64) -> Matrix3<f64> {
    let d = r.norm();
    let i = Matrix3::identity();
    if d == 0.0 {
        // r < 2a branch at r = 0: the two spheres coincide, (1 - 0) I.
        return i;
    }
    let rr = r * r.transpose() / (d * d);
    if d >= 2.0 * a {
        let x = a / d;
        let x3 = x * x * x;
        i * (0.75 * x + 0.5 * x3) + rr * (0.75 * x - 1.5 * x3)
    } else {
        let y = d / a;
        i * (1.0 - 9.0 * y / 32.0) + rr * (3.0 * y / 32.0)
    }
}

/// Oseen pair block in units of 1/(6 pi eta a): (3a / (4 r)) (I + r r^T / r^2) (eq. 6.9 times
/// 6 pi eta a / kB T). `None` at r = 0, where it is singular.
pub fn oseen_pair(r: &Vector3<f64>, a: f64) -> Option<Matrix3<f64>> {
    let d = r.norm();
    if d == 0.0 {
        return None;
    }
    let rr = r * r.transpose() / (d * d);
    Some((Matrix3::identity() + rr) * (0.75 * a / d))
}

/// The 3N x 3N mobility matrix (m/(N s)) of identical spheres of radius `radius` (m) at
/// `positions` (m) in a fluid of viscosity `viscosity` (Pa s). Block (i, j) is the 3x3
/// mobility coupling the force on j to the velocity of i. Oseen refuses coincident centres,
/// naming the pair.
pub fn mobility_matrix(
    kind: Hydrodynamics,
    positions: &[Vector3<f64>],
    radius: f64,
    viscosity: f64,
) -> Result<DMatrix<f64>> {
    let mu0 = stokes_mobility(viscosity, radius)?;
    let n = positions.len();
    let mut m = DMatrix::<f64>::zeros(3 * n, 3 * n);
    for i in 0..3 * n {
        m[(i, i)] = mu0;
    }
    if kind == Hydrodynamics::FreeDraining {
        return Ok(m);
    }
    for i in 0..n {
        for j in (i + 1)..n {
            let r = positions[i] - positions[j];
            let b = match kind {
                Hydrodynamics::Rpy => rpy_pair(&r, radius),
                Hydrodynamics::Oseen => match oseen_pair(&r, radius) {
                    Some(b) => b,
                    None => {
                        return invalid(format!(
                            "particles {i} and {j} coincide at {:?} m: the Oseen tensor \
                             (eq. 6.9) is singular at r = 0 (use RPY)",
                            positions[i]
                        ))
                    }
                },
                Hydrodynamics::FreeDraining => unreachable!(),
            } * mu0;
            for p in 0..3 {
                for q in 0..3 {
                    // Both blocks are symmetric 3x3 matrices; (j, i) is the transpose of (i, j).
                    m[(3 * i + p, 3 * j + q)] = b[(p, q)];
                    m[(3 * j + q, 3 * i + p)] = b[(p, q)];
                }
            }
        }
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn branches_meet_at_contact() {
        let a = 1.3e-7;
        let e = Vector3::new(0.0, 0.0, 1.0);
        let far = rpy_pair(&(e * 2.0 * a), a);
        let near = rpy_pair(&(e * (2.0 * a * (1.0 - 1e-15))), a);
        assert!((far - near).abs().max() < 1e-14);
        assert!((far[(0, 0)] - 7.0 / 16.0).abs() < 1e-15);
        assert!((far[(2, 2)] - 10.0 / 16.0).abs() < 1e-15);
    }

    #[test]
    fn oseen_coincident_named() {
        let p = vec![
            Vector3::zeros(),
            Vector3::new(1e-6, 0.0, 0.0),
            Vector3::zeros(),
        ];
        let e = mobility_matrix(Hydrodynamics::Oseen, &p, 1e-7, 1e-3)
            .unwrap_err()
            .to_string();
        assert!(e.contains("particles 0 and 2"), "{e}");
    }

    #[test]
    fn free_draining_is_diagonal() {
        let p = vec![Vector3::zeros(), Vector3::new(3e-7, 0.0, 0.0)];
        let m = mobility_matrix(Hydrodynamics::FreeDraining, &p, 1e-7, 1e-3).unwrap();
        let mu0 = 1.0 / (6.0 * PI * 1e-3 * 1e-7);
        assert_eq!(m.nrows(), 6);
        assert!((m[(0, 0)] - mu0).abs() <= 1e-15 * mu0);
        assert_eq!(m[(0, 3)], 0.0);
    }
}
