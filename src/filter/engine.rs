//! The filter engine: dilute magnetic nanoparticles carried through a fibre bed by a steady
//! flow, each one an independent overdamped Brownian walker (thesis 003, eq. 6.3 and 6.7 with
//! the free-draining mobility eq. 6.8: dx = (u(x) + mu F(x)) dt + sqrt(2 D dt) xi, D = kB T mu,
//! F = mu0 (m . grad) H, eq. 6.20), captured on touching a fibre, passed at the outlet. The
//! carrier flow u has no slip on the exact fibre surfaces ([`super::wall`]).

use super::bed::FibreBed;
use super::flow::VelocityLattice;
use super::setup::Setup;
use super::wall::{no_slip_flow, Wall};
use crate::brownian::{
    magnetic_dipole_force, run_rng, standard_normal, stokes_mobility, FieldSource, Fluid,
    LangevinMoment,
};
use crate::error::{invalid, Result};
use nalgebra::Vector3;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// Largest number of halvings of one particle's step before the run is refused.
const MAX_HALVINGS: u32 = 60;

/// Where a particle is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fate {
    Inside,
    /// Touched fibre `fibre` at `time_s`, centre at `position` (x, y in the cell; z the depth).
    Captured {
        fibre: usize,
        time_s: f64,
        position: Vector3<f64>,
    },
    /// Crossed the outlet plane at `time_s`.
    Passed {
        time_s: f64,
    },
}

/// One particle: its centre (x, y wrapped into the cell, z the unwrapped depth in m), the
/// deepest z it has reached, its fate and its own random stream.
#[derive(Debug, Clone)]
pub struct Tracer {
    pub position: Vector3<f64>,
    pub max_depth_m: f64,
    pub fate: Fate,
    rng: ChaCha8Rng,
}

impl Tracer {
    /// The word position of the particle's random stream.
    pub(super) fn rng_word_pos(&self) -> u128 {
        self.rng.get_word_pos()
    }
    pub(super) fn set_rng_word_pos(&mut self, pos: u128) {
        self.rng.set_word_pos(pos);
    }
}

/// fed = captured + passed + inside, always (every particle is fed at t = 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Counts {
    pub fed: usize,
    pub captured: usize,
    pub passed: usize,
    pub inside: usize,
}

/// The filter coefficient lambda (1/m) of an exponential penetration P(z) = exp(-lambda z),
/// from the survival fractions cell by cell, with its standard error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterCoefficient {
    pub per_m: f64,
    pub standard_error_per_m: f64,
    /// The fitted fraction passing one cell, exp(-lambda L_z).
    pub cell_survival: f64,
}

/// A filter run (see [`Setup`]).
pub struct Filter {
    bed: FibreBed,
    flow: VelocityLattice,
    field: Option<Box<dyn FieldSource>>,
    moment: LangevinMoment,
    fluid: Fluid,
    mobility: f64,
    diffusion_m2_s: f64,
    dt_s: f64,
    max_step_m: f64,
    depth_m: f64,
    cells_deep: usize,
    tracers: Vec<Tracer>,
    time_s: f64,
    steps: u64,
}

impl Filter {
    /// Checks the setup and feeds the particles: particle i draws from stream i of the seed
    /// ([`run_rng`]) a voxel column of the inlet layer with probability proportional to its
    /// axial velocity and a point uniformly on that column's square; a particle fed in contact
    /// with a fibre is captured at t = 0.
    pub fn new(setup: Setup) -> Result<Filter> {
        setup.check()?;
        let a = setup.bed.particle_radius_m();
        let mobility = stokes_mobility(setup.fluid.viscosity_pa_s(), a)?;
        let diffusion_m2_s = setup.fluid.kt() * mobility;
        let bed = setup.bed.with_wall_layer(setup.wall_layer_m)?;
        let fibre_radius = bed.fibres().first().map_or(a, |f| f.radius);
        let max_step_m = setup.max_step_fraction * fibre_radius;
        let noise_m = (2.0 * diffusion_m2_s * setup.dt_s).sqrt();
        if noise_m > max_step_m {
            return invalid(format!(
                "filter time step dt_s = {} s: the thermal step sqrt(2 D dt) = {noise_m:e} m \
                 exceeds the largest step {max_step_m:e} m (max_step_fraction {} of the fibre \
                 radius); use a shorter step",
                setup.dt_s, setup.max_step_fraction
            ));
        }
        let weights = setup.flow.inlet_flux_weights();
        let total: f64 = weights.iter().sum();
        let cumulative: Vec<f64> = weights
            .iter()
            .scan(0.0, |s, w| {
                *s += w / total;
                Some(*s)
            })
            .collect();
        let n = setup.flow.voxels();
        let h = setup.flow.voxel_m();
        let tracers = (0..setup.particles)
            .map(|i| {
                let mut rng = run_rng(setup.seed, i as u64);
                let u: f64 = rand::Rng::gen(&mut rng);
                let column = cumulative
                    .partition_point(|&c| c <= u)
                    .min(weights.len() - 1);
                let (ci, cj) = (column % n[0], column / n[0]);
                let fx: f64 = rand::Rng::gen(&mut rng);
                let fy: f64 = rand::Rng::gen(&mut rng);
                let position = Vector3::new((ci as f64 + fx) * h, (cj as f64 + fy) * h, 0.0);
                let fate = match bed.touching(&position) {
                    Some(fibre) => Fate::Captured {
                        fibre,
                        time_s: 0.0,
                        position,
                    },
                    None => Fate::Inside,
                };
                Tracer {
                    position,
                    max_depth_m: 0.0,
                    fate,
                    rng,
                }
            })
            .collect();
        let depth_m = setup.cells_deep as f64 * bed.lengths_m()[2];
        Ok(Filter {
            bed,
            flow: setup.flow,
            field: setup.field,
            moment: setup.moment,
            fluid: setup.fluid,
            mobility,
            diffusion_m2_s,
            dt_s: setup.dt_s,
            max_step_m,
            depth_m,
            cells_deep: setup.cells_deep,
            tracers,
            time_s: 0.0,
            steps: 0,
        })
    }

    /// The drift velocity u + mu F (m/s) at `p` (m, any position), and the wall when `p` is
    /// within the no-slip layer of a fibre.
    fn drift(&self, p: &Vector3<f64>) -> (Vector3<f64>, Option<Wall>) {
        let (u, wall) = no_slip_flow(&self.flow, &self.bed, p);
        let v = match &self.field {
            None => u,
            Some(field) => {
                let (h, g) = field.h_and_gradient(&self.bed.wrap(p));
                let m = self.moment.moment(&h, self.fluid.kt());
                u + magnetic_dipole_force(&m, &g) * self.mobility
            }
        };
        (v, wall)
    }

    /// One step of dt for one particle from time `t0`, in substeps of at most `max_step_m` of
    /// drift, and within a fibre's no-slip layer of at most half the distance to it of the
    /// flow's approach ([`Wall::max_approach_m`]); the inlet plane z = 0 reflects.
    fn advance(&self, tr: &mut Tracer, t0: f64) -> Result<()> {
        let mut left = self.dt_s;
        let noise = self.fluid.temperature_k() > 0.0;
        while left > 0.0 {
            let (v, wall) = self.drift(&tr.position);
            if !v.iter().all(|c| c.is_finite()) {
                return invalid(format!(
                    "filter: drift velocity {v:?} m/s at {:?} m is not finite",
                    tr.position
                ));
            }
            let mut h = left;
            let mut halvings = 0;
            let too_long = |h: f64| {
                v.norm() * h > self.max_step_m
                    || wall.is_some_and(|w| w.approach_m_s * h > w.max_approach_m())
            };
            while too_long(h) {
                h *= 0.5;
                halvings += 1;
                if halvings > MAX_HALVINGS {
                    return invalid(format!(
                        "filter: drift {:e} m/s at {:?} m (wall {wall:?}) needs more than \
                         {MAX_HALVINGS} halvings of dt_s = {} s",
                        v.norm(),
                        tr.position,
                        self.dt_s
                    ));
                }
            }
            let mut p = tr.position + v * h;
            if noise {
                let s = (2.0 * self.diffusion_m2_s * h).sqrt();
                let xi = Vector3::from_fn(|_, _| standard_normal(&mut tr.rng));
                p += xi * s;
            }
            if p.z < 0.0 {
                p.z = -p.z;
            }
            let l = self.bed.lengths_m();
            p.x = p.x.rem_euclid(l[0]);
            p.y = p.y.rem_euclid(l[1]);
            left = if h == left { 0.0 } else { left - h };
            tr.position = p;
            tr.max_depth_m = tr.max_depth_m.max(p.z.min(self.depth_m));
            let t = t0 + (self.dt_s - left);
            if let Some(fibre) = self.bed.touching(&p) {
                tr.fate = Fate::Captured {
                    fibre,
                    time_s: t,
                    position: p,
                };
                return Ok(());
            }
            if p.z >= self.depth_m {
                tr.fate = Fate::Passed { time_s: t };
                return Ok(());
            }
        }
        Ok(())
    }

    /// Advances every particle still inside by dt_s (in parallel; each particle draws only from
    /// its own stream, so the result does not depend on the thread count).
    pub fn step(&mut self) -> Result<()> {
        let t0 = self.time_s;
        let mut tracers = std::mem::take(&mut self.tracers);
        let r = tracers
            .par_iter_mut()
            .filter(|t| t.fate == Fate::Inside)
            .try_for_each(|t| self.advance(t, t0));
        self.tracers = tracers;
        r?;
        self.steps += 1;
        self.time_s = self.steps as f64 * self.dt_s;
        Ok(())
    }

    /// Sets the particles and the step count (a restored checkpoint).
    pub(super) fn restore(&mut self, tracers: Vec<Tracer>, steps: u64) {
        self.tracers = tracers;
        self.steps = steps;
        self.time_s = steps as f64 * self.dt_s;
    }

    pub fn time_s(&self) -> f64 {
        self.time_s
    }
    pub fn steps(&self) -> u64 {
        self.steps
    }
    pub fn tracers(&self) -> &[Tracer] {
        &self.tracers
    }
    pub fn bed(&self) -> &FibreBed {
        &self.bed
    }
    pub fn depth_m(&self) -> f64 {
        self.depth_m
    }
    pub fn cells_deep(&self) -> usize {
        self.cells_deep
    }
    pub fn diffusion_m2_s(&self) -> f64 {
        self.diffusion_m2_s
    }

    pub fn counts(&self) -> Counts {
        let mut c = Counts {
            fed: self.tracers.len(),
            captured: 0,
            passed: 0,
            inside: 0,
        };
        for t in &self.tracers {
            match t.fate {
                Fate::Inside => c.inside += 1,
                Fate::Captured { .. } => c.captured += 1,
                Fate::Passed { .. } => c.passed += 1,
            }
        }
        c
    }

    /// Penetration P(z): the fraction of the fed particles that have reached depth `z` (m),
    /// with its binomial standard error sqrt(P (1 - P) / N).
    pub fn penetration(&self, z_m: f64) -> (f64, f64) {
        let n = self.tracers.len() as f64;
        let reached = self.tracers.iter().filter(|t| t.max_depth_m >= z_m).count() as f64;
        let p = reached / n;
        (p, (p * (1.0 - p) / n).sqrt())
    }

    /// The filter coefficient from the numbers N_k of particles that reached the end of cell k
    /// (N_0 = fed), for a run that has ended (no particle inside): the maximum-likelihood
    /// survival per cell s = sum_{k=1..n} N_k / sum_{k=0..n-1} N_k, lambda = -ln(s) / L_z, with
    /// the delta-method error sqrt(s (1 - s) / sum_{k<n} N_k) / (s L_z). None when no particle
    /// is captured or none survives a cell (lambda 0 or infinite).
    pub fn filter_coefficient(&self) -> Option<FilterCoefficient> {
        let lz = self.bed.lengths_m()[2];
        let reached: Vec<f64> = (0..=self.cells_deep)
            .map(|k| {
                let z = k as f64 * lz;
                self.tracers
                    .iter()
                    .filter(|t| k == 0 || t.max_depth_m >= z)
                    .count() as f64
            })
            .collect();
        let at_risk: f64 = reached[..self.cells_deep].iter().sum();
        let survived: f64 = reached[1..].iter().sum();
        let s = survived / at_risk;
        if !(s > 0.0 && s < 1.0) {
            return None;
        }
        let se_s = (s * (1.0 - s) / at_risk).sqrt();
        Some(FilterCoefficient {
            per_m: -s.ln() / lz,
            standard_error_per_m: se_s / (s * lz),
            cell_survival: s,
        })
    }
}
