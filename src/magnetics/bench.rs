//! `porelab bench field`: points per second against error for the cylinder field.

use crate::Result;

#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Number of random points around the cylinder.
    #[arg(long, default_value_t = 1_000_000)]
    pub points: usize,
}

pub fn run(args: &BenchArgs) -> Result<()> {
    let _ = args;
    Err(crate::Error::Validation("bench field: not built yet".into()))
}
