//! Lattice-Boltzmann flow in clear and porous media (seed 002 eq. 3-11; Guo & Zhao 2002).
//!
//! One door: a typed [`Setup`] ([`setup`]: lattice, collision with its relaxation time,
//! forcing, domain with its walls, boundary planes, initial state) goes into [`Lbm::new`]
//! ([`engine`]), which builds the kernel the setup chooses ([`choice`], the one place the
//! choice is matched); [`Lbm::step`] advances it and [`driver`] runs it to its steady state.
//! [`problems`] holds the standard flows written once for any lattice and collision, [`pore`]
//! the permeability of a configuration voxelised by [`voxels`]; [`checkpoint`] saves a steady
//! run's state for a bitwise resume.
//!
//! The kernel's pieces (after lbmpy/waLBerla): the velocity set ([`lattice`]: D3Q15, D3Q19),
//! the collision ([`collision`]: BGK, TRT), the forcing ([`forcing`]: none, Guo body force,
//! Guo-Zhao porous medium), the geometry ([`geometry`]: periodic box, solid mask with halfway
//! bounce-back, moving walls) and the boundary planes ([`boundary`]: velocity and density by
//! non-equilibrium extrapolation, applied after the kernel). [`solver::Solver`] fuses the
//! first four into one kernel per choice. Everything inside is in lattice units (dx = dt = 1,
//! rho ~ 1); [`units`] converts at the boundary, refuses unstable parameters and holds the
//! only conversions between tau and the viscosity.

pub mod boundary;
pub mod checkpoint;
pub mod choice;
pub mod collision;
pub mod dims;
pub mod driver;
pub mod engine;
pub mod flows;
pub mod fluid;
pub mod forcing;
pub mod geometry;
pub mod ladder;
pub mod lattice;
pub mod memory;
pub mod pore;
pub mod problems;
pub mod setup;
pub mod simd;
pub mod solver;
#[cfg(test)]
mod tests;
pub mod units;
pub mod voxels;
pub mod walls;

pub use collision::{Bgk, Collision, Trt};
pub use driver::{run_steady, Steady, SteadyBar, SteadyControl};
pub use engine::Lbm;
pub use forcing::{BodyForce, Forcing, Porous, Unforced};
pub use geometry::{Dims, Geometry};
pub use lattice::{Lattice, D3Q15, D3Q19};
pub use setup::{
    Accel, CollisionKind, CollisionModel, Domain, ForcingModel, Initial, LatticeKind, Medium,
    PlaneCondition, PlaneSpec, PlaneVelocity, Setup, Storage, Tau, WallRule, Walls,
};
pub use solver::{Fields, Record, Solver};
