//! Lattice-Boltzmann flow in clear and porous media (seed 002 eq. 3-11; Guo & Zhao 2002).
//!
//! Pieces that a scene composes (after lbmpy/waLBerla): the velocity set ([`lattice`]: D3Q15,
//! D3Q19), the collision ([`collision`]: BGK, TRT), the forcing ([`forcing`]: none, Guo body
//! force, Guo-Zhao porous medium), the geometry ([`geometry`]: periodic box, solid mask with
//! halfway bounce-back, moving walls) and the boundary planes ([`boundary`]: velocity and
//! density by non-equilibrium extrapolation, applied after the kernel). [`solver::Solver`]
//! fuses the first four into one kernel per choice. Everything inside is in lattice units (dx = dt = 1, rho ~ 1); [`units`] converts at
//! the boundary and refuses unstable parameters.

pub mod boundary;
pub mod choice;
pub mod collision;
pub mod forcing;
pub mod geometry;
pub mod lattice;
pub mod memory;
pub mod pore;
pub mod problems;
pub mod simd;
pub mod solver;

pub use collision::{Bgk, Collision, Trt};
pub use forcing::{BodyForce, Forcing, Porous, Unforced};
pub use geometry::{Dims, Geometry};
pub use lattice::{Lattice, D3Q15, D3Q19};
pub use solver::{Fields, Record, Solver};
pub mod flows;
pub mod steady;
#[cfg(test)]
mod tests;
pub mod units;
