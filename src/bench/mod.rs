//! `porelab bench`: work-precision benchmarks of each kernel and engine, side by side with the
//! named peer where there is one (tables in `benches/RESULTS.md`). They sit beside the engines,
//! not inside them: an engine never imports its benchmark.

pub mod brownian;
pub mod coupled;
pub mod dem;
pub mod deposition;
pub mod field;
pub mod filter;
pub mod lbm;
pub mod packing;
pub mod sweep;
