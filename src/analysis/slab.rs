//! Exact volumes of posed ellipsoids between two heights, and the porosity of a layer on a
//! substrate against height (seed 000, "pore volume fraction").
//!
//! A horizontal slice of the ellipsoid x^T M x <= 1 (M = R diag(a^-2) R^T) at height t above
//! its centre is an ellipse of area A(t) = A0 (1 - t^2 / h^2), |t| <= h, where
//! h = sqrt((M^-1)_zz) = sqrt(sum_i (a_i R_zi)^2) is half the vertical extent and
//! A0 = pi a b c / h (so that the integral over [-h, h] is 4/3 pi a b c). The volume between
//! t1 and t2 is A0 [t - t^3 / (3 h^2)] over the clipped interval: no voxels.

use crate::error::{invalid, Result};
use nalgebra::{UnitQuaternion, Vector3};

/// An ellipsoid with semi-axes along its body axes, posed in the world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PosedEllipsoid {
    pub semi_axes: [f64; 3],
    pub position: Vector3<f64>,
    /// Body -> world.
    pub orientation: UnitQuaternion<f64>,
}

impl PosedEllipsoid {
    /// Half the vertical extent h.
    pub fn half_height(&self) -> f64 {
        let r = self.orientation.to_rotation_matrix().into_inner();
        let [a, b, c] = self.semi_axes;
        ((a * r[(2, 0)]).powi(2) + (b * r[(2, 1)]).powi(2) + (c * r[(2, 2)]).powi(2)).sqrt()
    }

    pub fn volume(&self) -> f64 {
        4.0 / 3.0 * std::f64::consts::PI * self.semi_axes.iter().product::<f64>()
    }

    /// The exact volume of the part between the heights z1 <= z2.
    pub fn volume_between(&self, z1: f64, z2: f64) -> f64 {
        let h = self.half_height();
        let t1 = (z1 - self.position.z).clamp(-h, h);
        let t2 = (z2 - self.position.z).clamp(-h, h);
        if t2 <= t1 {
            return 0.0;
        }
        let a0 = std::f64::consts::PI * self.semi_axes.iter().product::<f64>() / h;
        let prim = |t: f64| t - t * t * t / (3.0 * h * h);
        a0 * (prim(t2) - prim(t1))
    }
}

/// Solid fraction of the slab z1 <= z <= z2 of a box of horizontal area `area` (m^2).
pub fn solid_fraction_between(particles: &[PosedEllipsoid], area: f64, z1: f64, z2: f64) -> f64 {
    let v: f64 = particles.iter().map(|p| p.volume_between(z1, z2)).sum();
    v / (area * (z2 - z1))
}

/// One bin of a porosity profile.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ProfileBin {
    pub z_low_m: f64,
    pub z_high_m: f64,
    pub porosity: f64,
}

/// Porosity in `bins` equal slabs from the substrate to `top`.
pub fn porosity_profile(
    particles: &[PosedEllipsoid],
    area: f64,
    top: f64,
    bins: usize,
) -> Result<Vec<ProfileBin>> {
    if bins == 0 || !(top > 0.0 && top.is_finite()) {
        return invalid(format!(
            "porosity profile: {bins} bins up to {top} m: need at least one bin and a positive top"
        ));
    }
    let dz = top / bins as f64;
    let mut solid = vec![0.0f64; bins];
    for p in particles {
        let h = p.half_height();
        let lo = (((p.position.z - h) / dz).floor().max(0.0)) as usize;
        let hi = ((((p.position.z + h) / dz).ceil()) as usize).min(bins);
        for (k, s) in solid.iter_mut().enumerate().take(hi).skip(lo) {
            *s += p.volume_between(k as f64 * dz, (k + 1) as f64 * dz);
        }
    }
    Ok(solid
        .iter()
        .enumerate()
        .map(|(k, s)| ProfileBin {
            z_low_m: k as f64 * dz,
            z_high_m: (k + 1) as f64 * dz,
            porosity: 1.0 - s / (area * dz),
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slices_of_a_tilted_ellipsoid_sum_to_its_volume() {
        let e = PosedEllipsoid {
            semi_axes: [3.0, 1.0, 0.4],
            position: Vector3::new(0.0, 0.0, 5.0),
            orientation: UnitQuaternion::from_euler_angles(0.4, 1.0, -0.3),
        };
        let n = 37;
        let (lo, hi) = (0.0, 10.0);
        let total: f64 = (0..n)
            .map(|k| {
                let z1 = lo + (hi - lo) * k as f64 / n as f64;
                let z2 = lo + (hi - lo) * (k + 1) as f64 / n as f64;
                e.volume_between(z1, z2)
            })
            .sum();
        assert!((total - e.volume()).abs() < 1e-13 * e.volume());
    }
}
