//! What an MCM run is: the particles, the container, the random start and the compression
//! schedule of one or two stages (thesis sec. 2.2.1, 3.2), in reduced units (particle
//! diameter 1). [`Setup::check`] checks every value once, naming it and the rule; the engine
//! ([`super::Mcm::new`]) refuses a setup that fails it.

use super::{particle_volume, Container, ParticleShapes};
use crate::error::invalid;
use crate::Result;

/// Which overlap-removal scheme moves the particles (scene files: `"original"`, `"revised"`,
/// `"relax"`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Scheme {
    /// Thesis ch. 3 (eq. 3.2-3.13): Lagrange multiplier with the kinetic-energy constraint
    /// (mass = volume, full inertia tensor), step delta_min * dt, Rodrigues rotation.
    Revised,
    /// Thesis ch. 2 (eq. 2.4-2.10): velocities sum_j delta_ij k_ij (unit mass), rotation rate
    /// divided by xi = I_xy / m (the moment of inertia per unit mass, sec. 2.3), step
    /// beta * min_j delta_ij / (removal rate), axis renormalised.
    Original,
    /// Collective relaxation (module `relax`): all particles move at once down the gradient of the
    /// harmonic overlap energy (FIRE minimiser), as in the molecular-dynamics settling that
    /// Wouterse, Luding & Philipse (Granular Matter 11, 169, 2009; thesis ref. \[15\]) combine
    /// with the MCM; step `dt` is FIRE's initial time step. Same acceptance rule as the
    /// others: no overlap deeper than `overlap_tol`.
    Relax,
}

/// An MCM run (reduced units, see [`crate::packing`]): the particles, the container, the random
/// start (`phi0`, `seed`) and the schedule of the first stage, with an optional final stage.
#[derive(Debug, Clone)]
pub struct Setup {
    /// Number of particles (>= 2).
    pub n: usize,
    /// Cylinder length L between the hemisphere centres in diameters (0 = spheres); used
    /// when `particles` is None.
    pub length: f64,
    /// Per-particle shapes (mixtures, polydispersity, superquadrics); None: `n` equal
    /// particles of radius 1/2 and cylinder length `length` ([`ParticleShapes::monodisperse`]).
    pub particles: Option<ParticleShapes>,
    /// Packing fraction of the random start (0 < phi0 <= 0.2; thesis: 0.05).
    pub phi0: f64,
    /// Initial volume step per particle: Delta V = `delta_v_per_particle` * N (D^3).
    pub delta_v_per_particle: f64,
    /// How many times Delta V is halved after a failed step (thesis: typically 4).
    pub halvings: u32,
    /// Allowed particle moves per compression step, per particle (thesis: about 200).
    pub tries_per_particle: f64,
    /// Allowed particle moves over the whole stage (accepted and failed steps), per particle.
    /// None: unbounded, the thesis' schedule (a stage ends only when its halvings are spent).
    /// When the stage's budget runs out, the step in progress fails and the stage ends as if
    /// its halvings were spent; it keeps the moves per particle from growing with N.
    pub stage_budget_per_particle: Option<f64>,
    /// Overlaps not deeper than this count as removed (thesis sec. 2.2.6: 1e-4).
    pub overlap_tol: f64,
    /// Revised scheme: time step (thesis: 0.1).
    pub dt: f64,
    /// Revised scheme: kinetic-energy constant c of eq. 3.4 (thesis: 1).
    pub energy: f64,
    /// Original scheme: beta of eq. 2.10 (thesis: about 0.5).
    pub beta: f64,
    pub scheme: Scheme,
    pub seed: u64,
    /// Safety limit on accepted compression steps.
    pub max_steps: usize,
    /// Optional second stage, run from the configuration where the first one stopped, with
    /// its own Delta V, halvings, tries and step parameters (e.g. a compacting first stage with
    /// beta > 1 (original scheme), then a settling stage with the revised scheme, whose step
    /// delta_min dt approaches contact gradually, thesis sec. 3.5.2, and small Delta V).
    pub final_stage: Option<Stage>,
    /// The container (default: periodic cubic box).
    pub container: Container,
}

/// The schedule and step parameters of a further MCM stage (see [`Setup::final_stage`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stage {
    /// Overlap-removal scheme of this stage.
    pub scheme: Scheme,
    pub delta_v_per_particle: f64,
    pub halvings: u32,
    pub tries_per_particle: f64,
    /// See [`Setup::stage_budget_per_particle`].
    pub stage_budget_per_particle: Option<f64>,
    /// Original scheme: beta of eq. 2.10.
    pub beta: f64,
    /// Revised scheme: time step of eq. 3.9 and 3.12.
    pub dt: f64,
}

impl Setup {
    /// Spheres (L = 0) or spherocylinders of cylinder length `length` with the defaults above.
    pub fn new(n: usize, length: f64, seed: u64) -> Setup {
        Setup {
            n,
            length,
            particles: None,
            phi0: 0.05,
            delta_v_per_particle: 0.01,
            halvings: 6,
            tries_per_particle: 200.0,
            stage_budget_per_particle: None,
            overlap_tol: 1e-4,
            dt: 0.1,
            energy: 1.0,
            beta: 0.5,
            scheme: Scheme::Revised,
            seed,
            max_steps: 1_000_000,
            final_stage: None,
            container: Container::Periodic,
        }
    }

    /// The Gauss-Seidel-only two-stage sphere schedule of case 506 (`porelab bench packing`
    /// baseline `spheres_gs`): stage 1 as in `Setup::compacting_spheres` with Delta V
    /// halved 6 times and 3000 N tries; stage 2 revised scheme (eq. 3.6-3.13), dt = 0.1,
    /// Delta V = 0.001 N halved 6 times, 1000 N tries.
    pub fn two_stage_spheres(n: usize, seed: u64) -> Setup {
        let settle = Stage {
            scheme: Scheme::Revised,
            delta_v_per_particle: 0.001,
            halvings: 6,
            tries_per_particle: 1000.0,
            stage_budget_per_particle: None,
            beta: 0.5,
            dt: 0.1,
        };
        Setup::compacting_spheres(n, seed, 6, 3000.0, settle)
    }

    /// The jamming schedule for spheres (built-in scene `packing-spheres`, case 512, `porelab
    /// bench packing`): stage 1 as in `Setup::compacting_spheres` with 1000 N tries and
    /// Delta V halved twice, which compacts to about phi = 0.624; stage 2 the collective
    /// relaxation ([`Scheme::Relax`], FIRE initial step 0.1) from Delta V = 0.001 N halved 4
    /// times with 2000 N tries per step and at most 25000 N moves in all, which settles the
    /// contact network. The stage budget bounds the moves per particle, which otherwise grow with
    /// N as the relaxation creeps on near jamming (README.md at commit 2c48ccd, "Creep near jamming").
    pub fn jammed_spheres(n: usize, seed: u64) -> Setup {
        let relax = Stage {
            scheme: Scheme::Relax,
            delta_v_per_particle: 0.001,
            halvings: 4,
            tries_per_particle: 2000.0,
            stage_budget_per_particle: Some(25000.0),
            beta: 1.3, // unused by the relaxation; as stage 1 (what a scene file inherits)
            dt: 0.1,
        };
        Setup::compacting_spheres(n, seed, 2, 1000.0, relax)
    }

    /// Spheres with a compacting first stage (original scheme, eq. 2.7-2.10, beta = 1.3:
    /// over-relaxation; Delta V = 0.01 N halved `halvings` times, `tries` N tries per step;
    /// contact tolerance 1e-4) followed by `last`.
    fn compacting_spheres(n: usize, seed: u64, halvings: u32, tries: f64, last: Stage) -> Setup {
        let mut p = Setup::new(n, 0.0, seed);
        p.scheme = Scheme::Original;
        p.delta_v_per_particle = 0.01;
        p.halvings = halvings;
        p.overlap_tol = 1e-4;
        p.beta = 1.3;
        p.tries_per_particle = tries;
        p.final_stage = Some(last);
        p
    }

    /// Checks every parameter; the message names the value and the rule.
    pub fn validate(&self) -> Result<()> {
        if self.n < 2 {
            return invalid(format!("n = {}: need at least 2 particles", self.n));
        }
        if !(self.length.is_finite() && self.length >= 0.0) {
            return invalid(format!(
                "length = {}: cylinder length must be finite and >= 0 (0 = spheres)",
                self.length
            ));
        }
        if !(self.phi0.is_finite() && self.phi0 > 0.0 && self.phi0 <= 0.2) {
            return invalid(format!(
                "phi0 = {}: start packing fraction must be in (0, 0.2]",
                self.phi0
            ));
        }
        for (name, v) in [
            ("delta_v_per_particle", self.delta_v_per_particle),
            ("tries_per_particle", self.tries_per_particle),
            ("overlap_tol", self.overlap_tol),
            ("dt", self.dt),
            ("energy", self.energy),
            ("beta", self.beta),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return invalid(format!("{name} = {v}: must be positive and finite"));
            }
        }
        // eq. 2.10: a move by beta times an overlap leaves |1 - beta| of it, so from beta = 2 on
        // no move reduces an overlap and a "jammed" end would mean no compression at all.
        if self.beta >= 2.0 {
            return invalid(format!(
                "beta = {}: must be below 2 (a move of beta times the overlap leaves |1 - beta| \
                 of it; eq. 2.10, typically 0.5, over-relaxation up to about 1.5)",
                self.beta
            ));
        }
        if let Some(b) = self.stage_budget_per_particle {
            if !(b.is_finite() && b >= self.tries_per_particle) {
                return invalid(format!(
                    "stage_budget_per_particle = {b}: must be finite and at least \
                     tries_per_particle = {} (one step's budget)",
                    self.tries_per_particle
                ));
            }
        }
        if self.overlap_tol >= 0.1 {
            return invalid(format!(
                "overlap_tol = {}: must be below 0.1 diameters",
                self.overlap_tol
            ));
        }
        if self.halvings > 60 {
            return invalid(format!("halvings = {}: at most 60", self.halvings));
        }
        if let Some(p) = &self.particles {
            p.validate()?;
            if p.n() != self.n {
                return invalid(format!(
                    "n = {} but the particle table has {} particles: must be equal",
                    self.n,
                    p.n()
                ));
            }
            if p.has_superquadrics() {
                let stages = [Some(self.scheme), self.final_stage.map(|s| s.scheme)];
                if stages.contains(&Some(Scheme::Original)) {
                    return invalid(
                        "scheme = original: ellipsoids and superquadrics need the revised scheme \
                         (the original one, eq. 2.4-2.10, moves rods by their axis segment; \
                         thesis ch. 4 packs superquadrics with the revised MCM)",
                    );
                }
            }
        }
        // One compression step must leave free volume: Delta V below the start box's volume
        // minus the particles' volume (otherwise the first step, and every halving of it,
        // fails and the run ends at phi0 having compressed nothing).
        // (No per-particle table is built here: n may be refused for its memory later.)
        let mean_volume = match &self.particles {
            Some(p) => p.total_volume().unwrap_or(f64::NAN) / self.n as f64,
            None => particle_volume(self.length),
        };
        let free_per_particle = mean_volume * (1.0 / self.phi0 - 1.0);
        if self.delta_v_per_particle >= free_per_particle {
            return invalid(format!(
                "delta_v_per_particle = {} D^3: must be below the free volume per particle of \
                 the start, {free_per_particle:.4} D^3 (mean particle volume x (1/phi0 - 1), \
                 phi0 = {})",
                self.delta_v_per_particle, self.phi0
            ));
        }
        if self.final_stage.is_some() {
            self.stage_params(1)
                .validate()
                .map_err(|e| crate::Error::InvalidInput(format!("final stage: {e}")))?;
        }
        Ok(())
    }

    /// The parameters in force in stage `stage` (0: the main stage, 1: the final stage).
    pub fn stage_params(&self, stage: u32) -> Setup {
        match (stage, &self.final_stage) {
            (1, Some(st)) => Setup {
                scheme: st.scheme,
                delta_v_per_particle: st.delta_v_per_particle,
                halvings: st.halvings,
                tries_per_particle: st.tries_per_particle,
                stage_budget_per_particle: st.stage_budget_per_particle,
                beta: st.beta,
                dt: st.dt,
                final_stage: None,
                ..self.clone()
            },
            _ => self.clone(),
        }
    }

    /// The particles of the run: `particles`, or `n` equal ones of cylinder length `length`.
    pub fn particles(&self) -> ParticleShapes {
        self.particles
            .clone()
            .unwrap_or_else(|| ParticleShapes::monodisperse(self.n, self.length))
    }

    /// Number of stages (1 or 2).
    pub fn stages(&self) -> u32 {
        1 + self.final_stage.is_some() as u32
    }
}
