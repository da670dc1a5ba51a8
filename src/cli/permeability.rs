//! `porelab permeability PACKING.xyz`: the permeability of a periodic particle configuration by
//! the pore-resolving lattice Boltzmann solver ([`crate::lbm::pore`]), at half the resolution
//! and at the resolution asked for, with Darcy's law checked at half the force on the coarse
//! lattice.

use crate::error::Result;
use crate::io::xyz;
use crate::lbm::pore::{
    darcy_linearity, pore_permeability, report, setup_line, PoreOptions, DARCY_LINEARITY_TOL,
};
use crate::lbm::voxels::voxelise;
use crate::lbm::{CollisionKind, CollisionModel, LatticeKind, SteadyBar, SteadyControl, Tau};

#[derive(Debug, Clone, clap::Args)]
pub struct PermeabilityArgs {
    /// Extended XYZ configuration (periodic box), e.g. a packing's final.xyz.
    pub packing: std::path::PathBuf,
    /// Cells along the box's x edge; a second run at half of it gives the convergence estimate.
    #[arg(long, default_value_t = 64)]
    pub resolution: usize,
    /// The configuration's length unit in metres (e.g. the particle diameter), for k in m^2.
    #[arg(long)]
    pub unit_m: Option<f64>,
    /// D3Q15 or D3Q19.
    #[arg(long, default_value = "D3Q19")]
    pub lattice: String,
    /// bgk or trt (TRT: k independent of the viscosity).
    #[arg(long, default_value = "trt")]
    pub collision: String,
    /// Relaxation time.
    #[arg(long, default_value_t = 1.0)]
    pub tau: f64,
    /// Body force in lattice units (small: Re << 1).
    #[arg(long, default_value_t = 1e-6)]
    pub force: f64,
    /// Stop when the mean velocity changes by less than this (relative) over 100 steps.
    #[arg(long, default_value_t = 1e-7)]
    pub tol: f64,
    #[arg(long, default_value_t = 500_000)]
    pub max_steps: u64,
    #[arg(long)]
    pub quiet: bool,
}

/// `porelab permeability`.
pub fn run_permeability(a: &PermeabilityArgs) -> Result<()> {
    let text = std::fs::read_to_string(&a.packing).map_err(|e| crate::Error::File {
        path: a.packing.display().to_string(),
        msg: e.to_string(),
    })?;
    let (cell, parts) = xyz::parse(&text, &a.packing.display().to_string())?;
    let lattice = LatticeKind::parse(&a.lattice, "--lattice")?;
    let kind = CollisionKind::parse(&a.collision, "--collision")?;
    let ctl = SteadyControl {
        check_every: 100,
        tol: a.tol,
        max_steps: a.max_steps,
    };
    let collision = CollisionModel::new(kind, Tau::new(a.tau)?);
    let o = PoreOptions::new(lattice, collision, (a.force, "--force"), ctl)?;
    print!("{}", setup_line(&cell, &parts, &o));
    // one progress bar per steady run
    let bar = || SteadyBar::new(a.quiet);
    let mut results = Vec::new();
    let mut linearity = 0.0;
    for n in [a.resolution / 2, a.resolution] {
        let v = voxelise(&cell, &parts, n)?;
        let r = pore_permeability(&v, &o, &mut bar())?;
        print!("{}", report(&v, &r, &o, a.unit_m));
        if results.is_empty() {
            linearity = darcy_linearity(&v, &o, r.k, &mut bar())?;
        }
        results.push(r);
    }
    let (k1, k2) = (results[0].k, results[1].k);
    println!(
        "Darcy's law: k at half the force differs by {:+.2e} (resolution {}){}",
        linearity,
        results[0].n,
        if linearity.abs() > DARCY_LINEARITY_TOL {
            " -- NOT in the Darcy regime: lower --force"
        } else {
            ""
        }
    );
    println!(
        "convergence estimate: k changed by {:+.2} % from resolution {} to {}",
        100.0 * (k2 / k1 - 1.0),
        results[0].n,
        results[1].n
    );
    Ok(())
}
