//! The steady carrier flow of a filter: velocities (m/s) on the voxels of a periodic lattice
//! (an LBM solution through the bed, or any field sampled at the voxel centres), interpolated
//! trilinearly between voxel centres. Solid voxels hold zero velocity, so the interpolated flow
//! goes to zero at the fibres (no slip, to the lattice's resolution).

use crate::error::{invalid, require_positive, Result};
use nalgebra::Vector3;

/// Velocities on an n_x x n_y x n_z periodic lattice of cubic voxels; voxel (i, j, k) has its
/// centre at ((i + 1/2) h, (j + 1/2) h, (k + 1/2) h); x fastest in storage.
#[derive(Debug, Clone, PartialEq)]
pub struct VelocityLattice {
    n: [usize; 3],
    voxel_m: f64,
    velocity_m_s: Vec<Vector3<f64>>,
}

impl VelocityLattice {
    /// `velocity_m_s` holds n_x n_y n_z finite vectors, x fastest.
    pub fn new(n: [usize; 3], voxel_m: f64, velocity_m_s: Vec<Vector3<f64>>) -> Result<Self> {
        require_positive(voxel_m, || format!("flow lattice voxel size {voxel_m} m"))?;
        if n.iter().any(|&k| k < 2) {
            return invalid(format!(
                "flow lattice size {n:?}: needs at least 2 voxels along every axis"
            ));
        }
        if velocity_m_s.len() != n[0] * n[1] * n[2] {
            return invalid(format!(
                "flow lattice {n:?}: {} velocities given, {} needed",
                velocity_m_s.len(),
                n[0] * n[1] * n[2]
            ));
        }
        if let Some(i) = velocity_m_s
            .iter()
            .position(|v| !v.iter().all(|c| c.is_finite()))
        {
            return invalid(format!(
                "flow lattice velocity of voxel {i}: {:?} m/s must be finite",
                velocity_m_s[i]
            ));
        }
        Ok(VelocityLattice {
            n,
            voxel_m,
            velocity_m_s,
        })
    }

    /// The field `f` (position in m -> velocity in m/s) sampled at the voxel centres.
    pub fn from_fn(
        n: [usize; 3],
        voxel_m: f64,
        f: impl Fn(&Vector3<f64>) -> Vector3<f64>,
    ) -> Result<Self> {
        let v = (0..n[0] * n[1] * n[2])
            .map(|idx| {
                let (i, j, k) = (idx % n[0], (idx / n[0]) % n[1], idx / (n[0] * n[1]));
                f(&(Vector3::new(i as f64, j as f64, k as f64).add_scalar(0.5) * voxel_m))
            })
            .collect();
        VelocityLattice::new(n, voxel_m, v)
    }

    pub fn voxels(&self) -> [usize; 3] {
        self.n
    }
    pub fn voxel_m(&self) -> f64 {
        self.voxel_m
    }
    /// Edges of the periodic cell (m).
    pub fn lengths_m(&self) -> [f64; 3] {
        self.n.map(|k| k as f64 * self.voxel_m)
    }
    pub fn voxel_velocity(&self, i: usize, j: usize, k: usize) -> Vector3<f64> {
        self.velocity_m_s[(k * self.n[1] + j) * self.n[0] + i]
    }

    /// Trilinear interpolation between the eight voxel centres around `p` (m), periodic.
    pub fn at(&self, p: &Vector3<f64>) -> Vector3<f64> {
        let mut base = [0usize; 3];
        let mut frac = [0.0; 3];
        for a in 0..3 {
            let t = p[a] / self.voxel_m - 0.5;
            let f = t.floor();
            frac[a] = t - f;
            base[a] = (f as i64).rem_euclid(self.n[a] as i64) as usize;
        }
        let mut u = Vector3::zeros();
        for corner in 0..8 {
            let mut w = 1.0;
            let mut idx = [0usize; 3];
            for a in 0..3 {
                let up = (corner >> a) & 1 == 1;
                w *= if up { frac[a] } else { 1.0 - frac[a] };
                idx[a] = (base[a] + usize::from(up)) % self.n[a];
            }
            if w != 0.0 {
                u += self.voxel_velocity(idx[0], idx[1], idx[2]) * w;
            }
        }
        u
    }

    /// Flux weights of the inlet: for each voxel column (i, j) of the first layer (k = 0), the
    /// axial velocity u_z where positive, else 0; x fastest. Their sum times h^2 is the flow
    /// rate through the layer's voxel centres (m^3/s).
    pub fn inlet_flux_weights(&self) -> Vec<f64> {
        (0..self.n[0] * self.n[1])
            .map(|c| {
                self.voxel_velocity(c % self.n[0], c / self.n[0], 0)
                    .z
                    .max(0.0)
            })
            .collect()
    }

    /// The mean axial velocity over the whole lattice (solid voxels count as zero): the
    /// superficial velocity of the flow (m/s).
    pub fn superficial_velocity_m_s(&self) -> f64 {
        self.velocity_m_s.iter().map(|v| v.z).sum::<f64>() / self.velocity_m_s.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A field linear in each coordinate within one period is reproduced exactly between
    /// voxel centres, and the lattice is periodic.
    #[test]
    fn trilinear_is_exact_for_linear_fields_and_periodic() {
        let h = 1e-5;
        let l = VelocityLattice::from_fn([6, 5, 4], h, |p| {
            Vector3::new(p.x + 2.0 * p.y, 3.0 * p.z, 1.0)
        })
        .unwrap();
        let p = Vector3::new(2.3 * h, 1.7 * h, 2.1 * h);
        let u = l.at(&p);
        let want = Vector3::new(p.x + 2.0 * p.y, 3.0 * p.z, 1.0);
        assert!((u - want).norm() < 1e-12 * want.norm(), "{u} {want}");
        let shifted = l.at(&(p + Vector3::new(6.0 * h, -5.0 * h, 8.0 * h)));
        assert!((shifted - u).norm() < 1e-12 * u.norm());
        assert_eq!(
            l.at(&Vector3::new(0.5 * h, 0.5 * h, 0.5 * h)),
            l.voxel_velocity(0, 0, 0)
        );
    }

    #[test]
    fn bad_lattices_are_refused_by_name() {
        let e = VelocityLattice::new([2, 2, 2], 1e-5, vec![Vector3::zeros(); 7])
            .unwrap_err()
            .to_string();
        assert!(e.contains("7 velocities"), "{e}");
        let mut v = vec![Vector3::zeros(); 8];
        v[3].y = f64::NAN;
        let e = VelocityLattice::new([2, 2, 2], 1e-5, v)
            .unwrap_err()
            .to_string();
        assert!(e.contains("voxel 3"), "{e}");
        assert!(VelocityLattice::new([2, 2, 2], 0.0, vec![Vector3::zeros(); 8]).is_err());
    }
}
