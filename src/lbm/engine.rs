//! The lattice-Boltzmann engine's one door: [`Lbm::new`] builds the kernel a [`Setup`] chooses
//! and [`Lbm::step`] advances it; [`super::driver`] runs it to its steady state.

use super::choice::{build, Kernel};
use super::forcing::Porous;
use super::geometry::{Dims, Geometry};
use super::setup::{CollisionModel, LatticeKind, Setup};
use super::solver::{Fields, Record};
use crate::error::Result;

/// What the steady run's convergence test (`driver.rs`) carries from one check to the next: the
/// step the run started at (`max_steps` counts from it), the superficial mean velocity at the
/// last check, and the first residual (the progress scale). Kept on the engine at each check, so
/// that a checkpoint of the engine ([`super::checkpoint`]) is one of the run: the mean cannot
/// be read again from restored populations where boundary planes report the state they were
/// last rebuilt with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Monitor {
    pub start_steps: u64,
    pub mean_u: [f64; 3],
    pub first_residual: Option<f64>,
}

/// A lattice-Boltzmann flow (lattice units), built from a [`Setup`].
pub struct Lbm {
    kernel: Box<dyn Kernel>,
    lattice: LatticeKind,
    collision: CollisionModel,
    forcing: &'static str,
    /// The steady run's convergence monitor at its last check (a checkpoint saves it).
    pub(super) monitor: Option<Monitor>,
    /// A monitor restored from a checkpoint, which the next steady run continues from.
    pub(super) resumed: Option<Monitor>,
}

impl Lbm {
    /// Builds the flow of `setup`, at its initial state. Refuses what the setup's pieces could
    /// not check alone: a lattice larger than the memory available (before allocating), a
    /// boundary plane in the solid or without two fluid nodes behind each of its nodes, two
    /// planes sharing a node, an initial state of the wrong size.
    pub fn new(setup: Setup) -> Result<Lbm> {
        let (lattice, collision, forcing) = (setup.lattice, setup.collision, setup.forcing.name());
        Ok(Lbm {
            kernel: build(setup)?,
            lattice,
            collision,
            forcing,
            monitor: None,
            resumed: None,
        })
    }

    /// One time step: stream, bounce back, collide, rebuild the boundary planes.
    pub fn step(&mut self) -> Result<()> {
        self.kernel.run(1);
        Ok(())
    }

    /// `n` time steps.
    pub fn run(&mut self, n: u64) -> Result<()> {
        self.kernel.run(n);
        Ok(())
    }

    /// One time step that also records, per fluid cell, the density, velocity and source
    /// acceleration its collision used (refuses a record of another size than the lattice).
    pub fn step_recording(&mut self, rec: &mut Record) -> Result<()> {
        self.kernel.step_recording(rec)
    }

    /// Steps taken.
    pub fn steps(&self) -> u64 {
        self.kernel.steps()
    }

    pub fn lattice(&self) -> LatticeKind {
        self.lattice
    }

    pub fn collision(&self) -> CollisionModel {
        self.collision
    }

    /// The forcing's name.
    pub fn forcing_name(&self) -> &'static str {
        self.forcing
    }

    /// The kinematic viscosity of the kernel's collision (lattice units,
    /// [`CollisionModel::kernel_nu`]).
    pub fn nu(&self) -> f64 {
        self.collision.kernel_nu()
    }

    pub fn dims(&self) -> Dims {
        self.kernel.geometry().dims
    }

    /// The solid mask with its fluid runs and wall links.
    pub fn geometry(&self) -> &Geometry {
        self.kernel.geometry()
    }

    /// Density and velocity of every cell (the state the next collision sees).
    pub fn fields(&self) -> Fields {
        self.kernel.fields()
    }

    /// Total mass of the fluid cells.
    pub fn mass(&self) -> f64 {
        self.kernel.mass()
    }

    /// Total momentum of the fluid cells' post-collision populations.
    pub fn momentum(&self) -> [f64; 3] {
        self.kernel.momentum()
    }

    /// The post-collision populations (cells x Q, without the layout's padding), for a
    /// checkpoint.
    pub fn populations(&self) -> Vec<f64> {
        self.kernel.populations()
    }

    /// Restores populations saved by [`Lbm::populations`] and the step count.
    pub fn restore_populations(&mut self, f: &[f64], steps: u64) -> Result<()> {
        self.kernel.restore_populations(f, steps)
    }

    /// The Guo-Zhao medium, where the forcing is one.
    pub fn porous(&self) -> Option<&Porous> {
        self.kernel.porous()
    }

    /// The Guo-Zhao medium, to change cells between steps (its setters refuse bad values).
    pub fn porous_mut(&mut self) -> Option<&mut Porous> {
        self.kernel.porous_mut()
    }

    /// Whether the kernel stores its output non-temporally (see `Solver::streaming_stores`).
    pub fn streaming_stores(&self) -> bool {
        self.kernel.streaming_stores()
    }

    /// Chooses the kernel's stores (None: the default rule); the results are the same bits.
    pub fn set_streaming_stores(&mut self, on: Option<bool>) {
        self.kernel.set_streaming_stores(on)
    }

    /// Bytes the kernel holds (populations, neighbour tables, geometry).
    pub fn kernel_bytes(&self) -> usize {
        self.kernel.bytes()
    }

    /// Whether boundary planes `a` and `b` (in the order of the setup) are joined through
    /// fluid cells along the lattice's links, not wrapping across the planes' axes.
    pub fn planes_connected(&self, a: usize, b: usize) -> bool {
        self.kernel.planes_connected(a, b)
    }
}
