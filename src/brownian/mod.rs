//! Brownian dynamics of (magnetic) nanoparticles: the overdamped Langevin equation integrated by
//! the Ermak–McCammon update (thesis 003, chapter 6, eq. 6.3, 6.7, 6.11).
//!
//! SI units everywhere: positions and radii in m, temperature in K, viscosity in Pa s, time
//! in s, forces in N, magnetic moments in A m^2, fields H in A/m.
//!
//! - [`mobility`]: free-draining (eq. 6.8), Oseen (eq. 6.9) and Rotne–Prager–Yamakawa (eq. 6.10)
//!   mobility tensors as 3N x 3N matrices (the diffusion tensor is kB T times the mobility);
//! - [`noise`]: correlated random displacements by Cholesky factorisation (eq. 6.15–6.16) or by
//!   the TEA-HI approximation of Geyer & Winter (2009); not built without hydrodynamics;
//! - [`forces`]: shifted-truncated Mie(n, m) repulsion (eq. 6.18–6.19), point-dipole forces
//!   (eq. 6.21, 6.23), the Langevin magnetization law (eq. 6.22, 7.5–7.7), the force on a point
//!   dipole in an external field, constant forces;
//! - [`integrator`]: the update itself, with a time-step guard and initial-overlap check.
//!
//! The door: a [`Setup`] (`setup.rs`) describes a run; [`Simulation::new`] checks its start
//! and takes the run's random stream; [`Simulation::step`] is one step; [`driver`] runs a
//! simulation for a number of steps, sampling at intervals, with progress and stop hooks
//! ([`crate::driver::Hooks`]). The capture experiments of section 6.4 ([`experiment`]) are
//! built on these.
//!
//! Randomness: one `ChaCha8Rng` stream per independent run, derived from (seed, run index) by
//! [`run_rng`], so results do not depend on how runs are spread over threads.

pub mod capture;
pub mod driver;
pub mod experiment;
pub mod forces;
pub mod integrator;
pub mod magnetization;
pub mod mobility;
pub mod noise;
mod setup;

pub use forces::{
    dipole_energy, dipole_force, langevin, magnetic_dipole_force, FieldSource, LangevinMoment, Mie,
};
pub use integrator::Simulation;
pub use mobility::{mobility_matrix, stokes_mobility, Hydrodynamics};
pub use noise::{NoiseGenerator, NoiseMethod};
pub use setup::{Fluid, Magnetic, Setup, StepGuard};

use crate::error::{invalid, Result};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Identical spheres: centres (m) and the common radius (m).
#[derive(Debug, Clone, PartialEq)]
pub struct Particles {
    pub positions: Vec<Vector3<f64>>,
    pub radius: f64,
}

impl Particles {
    /// radius > 0 and finite, every position finite. Overlaps are checked by the integrator.
    pub fn new(positions: Vec<Vector3<f64>>, radius: f64) -> Result<Particles> {
        if !(radius.is_finite() && radius > 0.0) {
            return invalid(format!(
                "particle radius = {radius} m: must be positive and finite"
            ));
        }
        if let Some((i, p)) = positions
            .iter()
            .enumerate()
            .find(|(_, p)| !p.iter().all(|v| v.is_finite()))
        {
            return invalid(format!("particle {i} position {p:?} m: must be finite"));
        }
        Ok(Particles { positions, radius })
    }
    pub fn len(&self) -> usize {
        self.positions.len()
    }
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }
}

/// `n` positions on a simple cubic lattice of the given spacing (m), filled x fastest, then y,
/// then z, from the origin; ceil(cbrt n) sites per side.
pub fn cubic_lattice(n: usize, spacing: f64) -> Vec<Vector3<f64>> {
    let side = (n as f64).cbrt().ceil() as usize;
    (0..n)
        .map(|k| {
            Vector3::new(
                (k % side) as f64,
                ((k / side) % side) as f64,
                (k / (side * side)) as f64,
            ) * spacing
        })
        .collect()
}

/// The random stream of independent run `run` of a simulation seeded with `seed`: ChaCha8 keyed
/// by `seed`, stream number `run`. Streams never overlap, so a run's numbers depend only on
/// (seed, run), not on the thread that executes it.
pub fn run_rng(seed: u64, run: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(run);
    rng
}

/// One standard normal variate (Box–Muller on two uniforms in (0, 1]; exact in distribution).
pub fn standard_normal<R: rand::Rng + ?Sized>(rng: &mut R) -> f64 {
    // 1 - u with u in [0, 1) lies in (0, 1], so the logarithm is finite.
    let u1: f64 = 1.0 - rng.gen::<f64>();
    let u2: f64 = rng.gen::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    #[test]
    fn setup_rejects_bad_values() {
        assert!(Fluid::new(-1.0, 1e-3).is_err());
        assert!(Fluid::new(298.0, 0.0).is_err());
        let water = Fluid::new(298.0, 1e-3).unwrap();
        let one = Particles::new(vec![Vector3::zeros()], 1e-7).unwrap();
        let e = Setup::new(one, water, f64::NAN).err().unwrap().to_string();
        assert!(e.contains("dt"), "{e}");
        assert!(Particles::new(vec![Vector3::zeros()], 0.0).is_err());
        let e = Particles::new(
            vec![Vector3::zeros(), Vector3::new(f64::NAN, 0.0, 0.0)],
            1e-7,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("particle 1"), "{e}");
    }

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<u64> = (0..4).map(|_| run_rng(7, 3).gen()).collect();
        let mut r = run_rng(7, 3);
        let b: Vec<u64> = (0..4).map(|_| r.gen()).collect();
        assert_eq!(a[0], b[0]);
        let mut r2 = run_rng(7, 4);
        assert_ne!(r2.gen::<u64>(), b[0]);
    }

    #[test]
    fn normal_moments() {
        let mut r = run_rng(1, 0);
        let n = 200_000;
        let (mut s, mut s2) = (0.0, 0.0);
        for _ in 0..n {
            let g = standard_normal(&mut r);
            s += g;
            s2 += g * g;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        // 6 standard errors.
        assert!(mean.abs() < 6.0 / (n as f64).sqrt(), "{mean}");
        assert!((var - 1.0).abs() < 6.0 * (2.0 / n as f64).sqrt(), "{var}");
    }
}
