//! porelab: particles packing, depositing and being captured in random porous media,
//! with every printed number checked against an independent truth in `validation/`.
//!
//! Layout (see README): `special` (elliptic integrals, quadrature) -> `magnetics` (cylinder
//! fields) -> engines; `validation` runs the numbered cases, `reference` regenerates the
//! independent oracle tables without calling the code under test.

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
