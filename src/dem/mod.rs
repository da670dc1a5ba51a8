//! Discrete-element method for soft spheres (seed 002, Pianet, Bertrand, Vidal & Mallet 2011,
//! "DEM-based models for the consolidation of particle packings"): polydisperse spheres between
//! a floor and a top wall, periodic in x and y, with gravity, a uniform Stokes drag and a
//! pressure-controlled top wall as drivers.
//!
//! * [`setup`]: what a run is made of ([`Setup`]: box, contact model, materials, drivers, time
//!   step, start), checked once, and the values that follow from it (the time step, the skin).
//! * [`model`]: contact laws composed of normal, damping and tangential sub-models chosen
//!   separately (Hertz or linear spring; restitution or Zhou damping; Mindlin, linear or Zhou
//!   tangential spring with Coulomb friction), each checking its coefficients, and their
//!   combination checked once ([`ContactModel::new`]); walls use the same model as spheres of
//!   infinite radius and mass.
//! * [`lanes`]: contacts side by side (one `f64`, or four in an AVX register), so that the
//!   contact law is written once and the pair loop runs four pairs at a time, bit for bit.
//! * [`neighbour`]: cell list + half Verlet list with skin; tangential history per pair kept
//!   across rebuilds.
//! * [`engine`]: the velocity-Verlet integrator ([`Dem::new`] from a setup, [`Dem::step`],
//!   [`Dem::run`]) and the forces of gravity, drag and the walls.
//! * [`driver`]: runs a system to rest (stop rule, overlap refusal, progress and checkpoint
//!   hooks).
//! * [`particles`]: the spheres' dynamic state.
//! * [`start`]: the random overlap-free dispersion at a prescribed porosity.
//! * [`observe`]: porosity profiles from exact sphere–slab volumes, bed height.
//! * `team`: steps on two threads or more as one team: a leader publishes each loop, spinning
//!   helpers claim chunks of it.
//! * [`checkpoint`]: the exact dynamic state, for runs that resume bitwise.
//!
//! Vertical axis: z (the seed's x); SI units throughout.

pub mod checkpoint;
pub mod driver;
pub mod engine;
pub mod lanes;
pub mod model;
pub mod neighbour;
pub mod observe;
pub mod particles;
pub mod setup;
pub mod start;
mod team;

pub use driver::{run_to_rest, settle, Balance, Check, Progress, Rest, Stop, StopRule};
pub use engine::{ActiveTerms, Dem, WallLedger};
pub use model::{
    ContactModel, CoulombLimit, DampingModel, Material, NormalModel, PairMaterial, TangentialModel,
};
pub use particles::Particles;
pub use setup::{Drag, ImpactSpeed, Setup, Start, TimeStep, TopWall};
