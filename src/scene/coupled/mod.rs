//! Coupled LBM–DEM scenes (`kind = "coupled"`): a DEM bed (the `[dem]` table is a DEM scene,
//! [`super::dem`], without its `kind`) in a lattice-Boltzmann fluid driven by a pressure
//! gradient, two-way coupled by [`crate::coupled`]. SI units; z is the vertical.
//!
//! ```toml
//! kind = "coupled"
//! title = "..."
//! [dem]                               # a DEM scene: particles, box, contact, drivers, run
//! ...                                 # (drivers.fluid_density_kg_m3 is set to the fluid's)
//! [fluid]
//! dx_m = 4e-4                         # lattice spacing: lx, ly whole multiples (required)
//! tau = 0.8                           # BGK relaxation time [0.8]; dt = (tau - 1/2)/3 dx^2/nu
//! density_kg_m3 = 1000.0              # [1000]
//! viscosity_pa_s = 1e-3               # [1e-3]
//! pressure_gradient_pa_m = [0, 0, 0]  # imposed mean grad p; flow goes down for +z [0]
//! balance_weight = false              # add the gradient carrying the particles' weight [false]
//! [fluid.basesheet]                   # permeable bottom under the DEM floor [none]
//! thickness_m = 1e-3                  # h, whole cells; the lattice spans z = -h .. top
//! permeability_m2 = 1e-10             # K: Darcy drag -(mu/K) u, drop mu U h / K
//! [coupling]
//! overlap = "exact"                   # "exact" sphere-cube | "seed-lens" [exact]
//! drag_switch = "blend"               # "blend" (Huilin-Gidaspow) | "sharp" [blend]
//! eps_min = 0.1                       # porosity floor per cell [0.1]
//! dem_steps_per_lbm_step = 100        # M [100]
//! max_move_cells = 0.1                # refusal: displacement per coupling step [0.1]
//! max_relaxation = 0.5                # refusal: gamma dt_LBM / m [0.5]
//! frozen = false                      # fixed bed: particles do not move [false]
//! [output]
//! time_s = 0.1                        # simulated time (required)
//! frames_every_s = 0.05               # XYZ + VTK frames [time_s]
//! profile_every_s = 0.01              # porosity-profile rows [time_s / 20]
//! ```
//!
//! Outputs: `frame_NNNN.xyz` (particles) and `fluid_NNNN.vtk` (porosity, velocity m/s,
//! pressure deviation Pa) at the same times, `porosity_profile.csv` (time, z of each layer,
//! porosity), `summary.json`.

mod outputs;
mod run;
mod schema;
#[cfg(test)]
mod tests;

pub use outputs::{summarize, CoupledSummary};
pub use run::{build, run_scene};
pub use schema::{parse_scene, CoupledScene};

use super::{Builtin, RunOptions};
use crate::Result;
use std::path::Path;

pub fn builtins() -> Vec<Builtin> {
    vec![
        Builtin {
            name: "coupled-quick",
            about:
                "coupled LBM-DEM: 300 spheres d = 400 um consolidated by a drainage flow (seconds)",
            toml: include_str!("../builtin/coupled-quick.toml"),
        },
        Builtin {
            name: "coupled-seed-bed",
            about:
                "coupled LBM-DEM: seed 002 Fig. 12, 2014 spheres d = 400 um under a pressure drop",
            toml: include_str!("../builtin/coupled-seed-bed.toml"),
        },
    ]
}

/// `kind = "coupled"`.
pub struct Kind;

/// The work a coupled scene may ask for: lattice cells times LBM steps to `output.time_s`.
pub const MAX_CELL_UPDATES: f64 = 1e12;

/// Everything a run checks before it allocates the lattice ([`crate::coupled::Coupled::plan`]:
/// the setup and the memory), and the work: cells times LBM steps up to `output.time_s`, at
/// most `output.max_cell_updates` [[`MAX_CELL_UPDATES`]].
pub(crate) fn check_size(scene: &CoupledScene) -> Result<()> {
    let plan = crate::coupled::Coupled::plan(&scene.setup)?;
    let d = plan.dims();
    let cells = (d.nx * d.ny * d.nz) as f64;
    let steps = (scene.time_s / plan.dt_lbm_s()).ceil();
    let limit = scene.max_cell_updates;
    if cells * steps > limit {
        return crate::error::invalid(format!(
            "a lattice of {} x {} x {} cells (fluid.dx_m = {} m) run for output.time_s = {} s \
             in {steps:.3e} steps of {:.3e} s is {:.3e} cell-updates, more than \
             output.max_cell_updates = {limit:e}: use a coarser fluid.dx_m or a shorter run, or \
             raise output.max_cell_updates to run it anyway",
            d.nx,
            d.ny,
            d.nz,
            scene.setup.dx_m,
            scene.time_s,
            plan.dt_lbm_s(),
            cells * steps
        ));
    }
    Ok(())
}

impl super::Scene for Kind {
    fn kind(&self) -> &'static str {
        "coupled"
    }
    fn builtins(&self) -> Vec<Builtin> {
        builtins()
    }
    fn seed_key(&self) -> Option<&'static str> {
        Some("dem.seed")
    }
    fn check(&self, text: &str, origin: &str) -> Result<()> {
        // everything a run checks before it allocates the lattice
        check_size(&parse_scene(text, origin)?)
    }
    fn run(&self, text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
        run_scene(text, origin, out, opts)
    }
}
