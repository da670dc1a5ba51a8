//! What a Brownian-dynamics run is (thesis 003, ch. 6): the particles, the solvent, the time
//! step, and the terms of the Ermak–McCammon update that the run builds (hydrodynamics and
//! its noise, repulsion, magnetic forces, a constant force, capture), with the step guard.
//! [`Fluid::new`] checks the solvent and [`Setup::new`] the time step once; the engine
//! ([`super::Simulation::new`]) checks the start (overlaps, particles inside a cylinder).

use super::capture::CaptureSet;
use super::forces::{FieldFn, FieldSource, LangevinMoment, Mie};
use super::mobility::Hydrodynamics;
use super::noise::NoiseMethod;
use super::Particles;
use crate::consts::{KB, MU0};
use crate::error::{invalid, require_positive, Result};
use nalgebra::{Matrix3, Vector3};

/// The solvent: temperature (K; 0 switches the noise off) and viscosity (Pa s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fluid {
    temperature_k: f64,
    viscosity_pa_s: f64,
}

impl Fluid {
    /// temperature >= 0, viscosity > 0, both finite.
    pub fn new(temperature_k: f64, viscosity_pa_s: f64) -> Result<Fluid> {
        if !(temperature_k.is_finite() && temperature_k >= 0.0) {
            return invalid(format!(
                "temperature = {temperature_k} K: must be finite and >= 0"
            ));
        }
        if !(viscosity_pa_s.is_finite() && viscosity_pa_s > 0.0) {
            return invalid(format!(
                "viscosity = {viscosity_pa_s} Pa s: must be positive and finite"
            ));
        }
        Ok(Fluid {
            temperature_k,
            viscosity_pa_s,
        })
    }

    pub fn temperature_k(&self) -> f64 {
        self.temperature_k
    }

    pub fn viscosity_pa_s(&self) -> f64 {
        self.viscosity_pa_s
    }

    /// Thermal energy kB T (J).
    pub fn kt(&self) -> f64 {
        KB * self.temperature_k
    }
}

/// Refuses a time step that is not positive and finite.
pub(super) fn check_time_step(dt_s: f64) -> Result<()> {
    if !(dt_s.is_finite() && dt_s > 0.0) {
        return invalid(format!(
            "time step dt = {dt_s} s: must be positive and finite"
        ));
    }
    Ok(())
}

/// What to do when the deterministic displacement of a step is too large for the repulsion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepGuard {
    /// Refuse with an Err when any |M F dt| > max_fraction * R.
    Refuse { max_fraction: f64 },
    /// Halve the step until |M F dt| <= max_fraction * R, at most `max_halvings` times.
    Substep {
        max_fraction: f64,
        max_halvings: u32,
    },
}

impl Default for StepGuard {
    fn default() -> Self {
        StepGuard::Refuse { max_fraction: 0.1 }
    }
}

/// Magnetic terms: a field source, the moment law, and the dipole–dipole cut-off (m; default
/// 30 R in the thesis). `dipole_pairs = false` leaves out the particle–particle dipole forces.
pub struct Magnetic {
    pub source: Box<dyn FieldSource>,
    pub moment: LangevinMoment,
    pub dipole_pairs: bool,
    pub cutoff: f64,
}

/// Moment (A m^2) and field (A/m) used by [`Magnetic::harmonic_trap`]; any non-zero values give the
/// same force.
const TRAP_MOMENT: f64 = 1e-16;
const TRAP_FIELD: f64 = 1e5;

impl Magnetic {
    /// The magnetic terms that make the force on every particle F = -k r (N), r its position (m),
    /// `stiffness` k in N/m (no dipole pairs).
    pub fn harmonic_trap(stiffness: f64) -> Result<Self> {
        require_positive(stiffness, || format!("trap stiffness k = {stiffness} N/m"))?;
        let c = -stiffness / (MU0 * TRAP_MOMENT);
        let source = FieldFn(move |p: &Vector3<f64>| {
            let mut g = Matrix3::zeros();
            g.set_column(0, &(p * c));
            (Vector3::new(TRAP_FIELD, 0.0, 0.0), g)
        });
        Ok(Magnetic {
            source: Box::new(source),
            moment: LangevinMoment::fixed(TRAP_MOMENT)?,
            dipole_pairs: false,
            cutoff: 0.0,
        })
    }
}

/// A Brownian-dynamics run of identical spheres: the start, the solvent, the time step and the
/// terms to build. [`Setup::new`] gives free particles (no forces), free-draining, the default
/// guard and no capture; the other terms are set on the fields.
pub struct Setup {
    pub particles: Particles,
    pub fluid: Fluid,
    /// Time step (s).
    pub dt_s: f64,
    pub hydrodynamics: Hydrodynamics,
    /// Used only when `hydrodynamics` is not free-draining.
    pub noise: NoiseMethod,
    pub repulsion: Option<Mie>,
    pub magnetic: Option<Magnetic>,
    /// A constant force (N) on every particle.
    pub constant_force: Vector3<f64>,
    pub guard: StepGuard,
    /// Whether the guard counts the external-field force (default true; see `integrator.rs`).
    pub guard_field_force: bool,
    /// Capture by cylinders (None: no capture), for the same number of particles.
    pub capture: Option<CaptureSet>,
}

impl Setup {
    /// Free particles of `fluid` stepped by `dt_s` (positive and finite).
    pub fn new(particles: Particles, fluid: Fluid, dt_s: f64) -> Result<Setup> {
        check_time_step(dt_s)?;
        Ok(Setup {
            particles,
            fluid,
            dt_s,
            hydrodynamics: Hydrodynamics::FreeDraining,
            noise: NoiseMethod::Cholesky,
            repulsion: None,
            magnetic: None,
            constant_force: Vector3::zeros(),
            guard: StepGuard::default(),
            guard_field_force: true,
            capture: None,
        })
    }

    /// Human-readable list of the terms that are built and used.
    pub fn active_terms(&self) -> Vec<String> {
        let mut t = vec![format!("mobility: {}", self.hydrodynamics.scene_name())];
        if self.fluid.temperature_k() > 0.0 {
            t.push(match self.hydrodynamics {
                Hydrodynamics::FreeDraining => "noise: independent (no HI)".to_string(),
                _ => format!("noise: {:?}", self.noise),
            });
        } else {
            t.push("noise: off (T = 0)".into());
        }
        if self.constant_force != Vector3::zeros() {
            t.push(format!("constant force {:?} N", self.constant_force));
        }
        if let Some(m) = &self.repulsion {
            t.push(format!("Mie({}, {}) repulsion", m.n, m.m));
        }
        if let Some(c) = &self.capture {
            t.push(format!("capture by {} cylinder(s)", c.bodies.len()));
        }
        if let Some(m) = &self.magnetic {
            t.push("external field force".into());
            if m.dipole_pairs {
                t.push(format!("dipole-dipole (cut-off {:e} m)", m.cutoff));
            }
        }
        t
    }
}
