//! `porelab field`: the field at the points of a CSV file.

use crate::Result;
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub struct FieldArgs {
    /// Cylinder radius R in m.
    #[arg(long)]
    pub radius: f64,
    /// Cylinder semi-length L in m (the cylinder spans [-L, L] along its axis).
    #[arg(long = "half-length")]
    pub half_length: f64,
    /// Magnetization MX,MY,MZ in A/m (world frame).
    #[arg(long, allow_hyphen_values = true)]
    pub magnetization: String,
    /// Centre X,Y,Z in m.
    #[arg(long, default_value = "0,0,0", allow_hyphen_values = true)]
    pub centre: String,
    /// Axis direction AX,AY,AZ.
    #[arg(long, default_value = "0,0,1", allow_hyphen_values = true)]
    pub axis: String,
    /// Also write the nine components dH_i/dx_j in A/m^2.
    #[arg(long)]
    pub gradient: bool,
    /// CSV file with header x,y,z (m).
    #[arg(long)]
    pub points: std::path::PathBuf,
}

pub fn run_field(args: &FieldArgs) -> Result<ExitCode> {
    let _ = args;
    Err(crate::Error::Validation("field: not built yet".into()))
}
