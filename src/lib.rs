//! porelab: particles packing, depositing and being captured in random porous media,
//! with every printed number checked against an independent truth in `validation/`.
//!
//! Layout: see the README's "The code's layout" (kernels, engines with one door each, floors);
//! `tests/architecture.rs` holds imports to it.
//!
//! Two walks from a scene file to the kernel:
//!
//! - the DEM time step: `[run] dt_s` is read by `scene/dem/schema.rs` into `dem::TimeStep::Given`
//!   (absent: `TimeStep::Automatic`); `Dem::new` checks it once against the contact and Rayleigh
//!   times (`dem::Setup::check_time_step`) and keeps it private; the coupled engine sets its own
//!   dt_LBM / M through `Dem::with_time_step`, which checks it the same way, and refuses a given one;
//! - the LBM relaxation time: `tau` is read by `scene/lbm/schema.rs` (or `scene/coupled/schema.rs`)
//!   into `lbm::Tau` (refused below its stability floor), joined with the collision kind into a
//!   `CollisionModel`; `Lbm::new` builds the kernel it selects (`lbm/choice.rs`, the one match), and
//!   the viscosity it implies, nu = (tau - 1/2)/3, is computed only in `lbm/units.rs`.

pub mod analysis;
pub mod bench;
pub mod brownian;
pub mod cli;
pub mod consts;
pub mod contact;
pub mod coupled;
pub mod dem;
pub mod deposition;
pub mod driver;
pub mod error;
pub mod filter;
pub mod hydro;
pub mod io;
pub mod lbm;
pub mod magnetics;
pub mod packing;
pub mod reference;
pub mod scene;
pub mod shape;
pub mod special;
pub mod sweep;
pub mod validation;

pub use error::{Error, Result};
