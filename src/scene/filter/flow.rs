//! The carrier flow of a filter scene: the steady Stokes flow through the bed's fibres from the
//! lattice Boltzmann engine ([`crate::lbm::problems::permeability`], a body force along the
//! lattice's x), on the voxels of the filter cell, with its permeability. The engine drives
//! along x and the filter's flow runs along z, so the lattice is the cell with its axes turned
//! cyclically (lattice x, y, z = cell z, x, y), which keeps handedness.
//!
//! At low Reynolds number the steady flow is linear in its drive, so the flow at any
//! superficial velocity U is the computed one scaled by U / <u> (a scene refuses a fibre
//! Reynolds number above 1, where inertia would break that scaling).

use crate::driver::Hooks;
use crate::error::{invalid, Result};
use crate::filter::{FibreBed, VelocityLattice};
use crate::lbm::problems::permeability;
use crate::lbm::{CollisionKind, CollisionModel, Dims, Domain, Lbm, SteadyControl, Tau};
use crate::lbm::{LatticeKind, Steady};
use nalgebra::Vector3;

/// How the lattice flow is solved.
#[derive(Debug, Clone, Copy)]
pub struct LatticeOptions {
    pub lattice: LatticeKind,
    pub collision: CollisionKind,
    pub tau: f64,
    /// Body force (lattice units).
    pub force_lattice: f64,
    pub ctl: SteadyControl,
}

/// The flow through a bed, scaled to unit superficial velocity.
pub struct BedFlow {
    /// Voxel velocities over the superficial velocity (x fastest, the cell's axes).
    pub shape: Vec<Vector3<f64>>,
    pub voxels: [usize; 3],
    pub voxel_m: f64,
    /// Darcy permeability along z (m^2) and the fluid fraction of the voxels.
    pub permeability_m2: f64,
    pub porosity: f64,
    /// The lattice run: its steps, its residual, whether it converged, the largest lattice
    /// velocity (for the Mach number).
    pub steady_steps: u64,
    pub residual: f64,
    pub converged: bool,
    pub u_max_lattice: f64,
}

impl BedFlow {
    /// The flow at superficial velocity `u_m_s` as the filter engine's lattice.
    pub fn at(&self, u_m_s: f64) -> Result<VelocityLattice> {
        VelocityLattice::new(
            self.voxels,
            self.voxel_m,
            self.shape.iter().map(|v| v * u_m_s).collect(),
        )
    }
}

/// Solves the flow through `bed` on `voxels` cubic voxels (the cell's x, y, z): a voxel is
/// solid when its centre is inside a fibre or one of its periodic images.
pub fn bed_flow(
    bed: &FibreBed,
    voxels: [usize; 3],
    o: &LatticeOptions,
    hooks: &mut dyn Hooks<Lbm>,
) -> Result<BedFlow> {
    let l = bed.lengths_m();
    let h = l[0] / voxels[0] as f64;
    let [nx, ny, nz] = voxels;
    // lattice (a, b, c) = cell (k, i, j)
    let dims = Dims::new(nz, nx, ny)?;
    let centre = |i: usize, j: usize, k: usize| {
        Vector3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * h
    };
    let solid: Vec<bool> = (0..dims.cells())
        .map(|c| {
            let [k, i, j] = dims.coords(c);
            bed.inside(&centre(i, j, k))
        })
        .collect();
    let domain = Domain::with_solid(dims, solid)?;
    let collision = CollisionModel::new(o.collision, Tau::new(o.tau)?);
    let run = permeability(o.lattice, collision, domain, o.force_lattice, o.ctl, hooks)?;
    let Steady {
        fields,
        mean_u,
        residual,
        steps,
        converged,
        u_max,
    } = run.steady;
    let shape = (0..nx * ny * nz)
        .map(|idx| {
            let (i, j, k) = (idx % nx, (idx / nx) % ny, idx / (nx * ny));
            let u = fields.u[dims.cell(k, i, j)];
            Vector3::new(u[1], u[2], u[0]) / mean_u[0]
        })
        .collect();
    Ok(BedFlow {
        shape,
        voxels,
        voxel_m: h,
        permeability_m2: run.k * h * h,
        porosity: run.porosity,
        steady_steps: steps,
        residual,
        converged,
        u_max_lattice: u_max,
    })
}

/// Largest fibre Reynolds number rho U (2 R) / mu the Stokes scaling of the flow accepts.
pub const MAX_REYNOLDS: f64 = 1.0;

/// The fibre Reynolds number rho U (2 R) / mu of superficial velocity `u_m_s`, refused above
/// [`MAX_REYNOLDS`].
pub fn fibre_reynolds(u_m_s: f64, density_kg_m3: f64, radius_m: f64, mu_pa_s: f64) -> Result<f64> {
    let re = density_kg_m3 * u_m_s * 2.0 * radius_m / mu_pa_s;
    if re > MAX_REYNOLDS {
        return invalid(format!(
            "flow: superficial velocity {u_m_s:e} m/s gives the fibre Reynolds number \
             rho U 2R / mu = {re:.3}, above {MAX_REYNOLDS}: the flow is the Stokes flow scaled \
             to U, which inertia would break; lower the flow"
        ));
    }
    Ok(re)
}
