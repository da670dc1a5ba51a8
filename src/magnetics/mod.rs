//! Magnetic fields of uniformly magnetized finite cylinders (thesis 003, chapter 5).
//!
//! Conventions: SI throughout (m, A/m, T); a [`Cylinder`] is centred at the origin of its own
//! frame with its axis along z and spans z in [-L, L]; a [`Magnet`] places one in the world
//! (centre, axis) with a magnetization given in world coordinates; an [`Assembly`] sums magnets.
//! H is the field of the magnetization alone (no external field); B = mu0 (H + M inside).

pub mod assembly_fast;
pub mod cylinder;
pub mod cylinder_table;
pub mod kernel;
pub mod magnet;

pub use cylinder::Cylinder;
pub use magnet::{Assembly, Magnet};
