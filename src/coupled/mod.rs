//! Two-way coupled LBM–DEM (seed 002, "Fluid–particle coupling" and "Two-way coupling
//! algorithm", eq. 10-11, Fig. 12): the particles of [`crate::dem`] seen by the fluid of
//! [`crate::lbm`] as a porous medium whose porosity and permeability follow them, and the
//! fluid's drag returned to the particles. Composes both engines through their public APIs:
//! the DEM's per-particle external force, the LBM's per-cell Guo–Zhao fields (porosity, drag
//! coefficients, matrix velocity) and its recorded step.
//!
//! * [`porosity`]: solid volume of spheres per cell, exact sphere ∩ cube or the seed's lens;
//! * [`drag`]: Carman–Kozeny K (eq. 11), Ergun / Wen–Yu drag and their switch;
//! * [`engine`]: the one door, [`Setup`] and [`Coupled::new`] / [`Coupled::step`]: the
//!   coupling loop, momentum balance and the run-time refusals;
//! * [`driver`]: runs a system to a step count or to a steady observable;
//! * [`checkpoint`]: the run's state, bitwise, for resuming.

pub mod checkpoint;
pub mod drag;
pub mod driver;
pub mod engine;
pub mod porosity;

pub use drag::Switch;
pub use driver::{run_to_steady, run_to_step, Steady, Stop};
pub use engine::{Balance, Basesheet, Coupled, Setup, Timing};
pub use porosity::Overlap;
