//! Magnetic filtration in a fibre bed (thesis 003, chapters 5-7 joined): a bed of identical
//! finite fibres in a cell periodic along x, y and z, a steady carrier flow along +z on a
//! lattice ([`VelocityLattice`], e.g. the LBM flow through the bed), the magnetic field of the
//! fibres (any [`FieldSource`](crate::brownian::FieldSource); the fibres' own superposition is
//! [`crate::magnetics::assembly_fast`]), and dilute magnetic nanoparticles.
//!
//! The model, stated:
//! - particles are independent (dilute: no particle-particle forces or hydrodynamics) and
//!   overdamped, with the free-draining Stokes mobility of the Brownian engine (thesis eq. 6.8)
//!   and its moment law ([`LangevinMoment`](crate::brownian::LangevinMoment));
//! - the carrier flow is the lattice's, with no slip on the exact fibre surfaces within a wall
//!   layer of about one voxel ([`wall`]);
//! - the fibres' magnetization is set from the applied field alone (mutual magnetization of
//!   the fibres neglected, as in thesis section 5.6);
//! - a particle touching a fibre (centre within one particle radius of the solid) is captured
//!   and stays; one crossing z = cells_deep L_z has passed; the inlet plane z = 0 reflects;
//!   x and y are periodic; depth is tracked through the periodic images along z, so a bed of
//!   n cells is the cell stacked n times;
//! - each particle draws from its own ChaCha stream (seed, particle index), so a run's results
//!   are the same at any thread count.
//!
//! The door: a [`Setup`], [`Filter::new`], [`Filter::step`]; [`driver`] runs to the end;
//! [`checkpoint`] saves and restores a run bitwise.

mod bed;
pub mod checkpoint;
pub mod driver;
mod engine;
mod field;
mod flow;
mod setup;
pub mod wall;

pub use bed::{random_transverse_fibres, FibreBed, Surface};
pub use engine::{Counts, Fate, Filter, FilterCoefficient, Tracer};
pub use flow::VelocityLattice;
pub use setup::Setup;

#[cfg(test)]
mod tests;
