//! Filter scenes (`kind = "filter"`): magnetic nanoparticles carried by the pore flow through
//! a bed of magnetized fibres and captured on them ([`crate::filter`]), from a packing's
//! configuration to the penetration against depth, in one run.
//!
//! Schema (keys optional unless marked; defaults in brackets):
//!
//! ```toml
//! kind = "filter"                   # required
//! title = "..."
//! [bed]                             # required
//! xyz = "final.xyz"                 # required: extended XYZ of identical spherocylinders in a
//!                                   # periodic box (a packing scene's final.xyz), relative to
//!                                   # the scene file, or "builtin:filter-rods.xyz"; each
//!                                   # becomes the solid cylinder of its radius and volume
//! fibre_radius_m = 2e-4             # required: the configuration is scaled to this radius
//! resolution = 24                   # required: flow-lattice voxels along the cell's x edge
//! cells_deep = 4                    # the cell stacked along the flow (z) [1]
//! [field]
//! applied_T = 1.0                   # applied flux density mu0 H0 (T); 0: no field [0]
//! direction = [0.0, 0.0, 1.0]       # of the applied field [along the flow]
//! saturation_a_per_m = 985e3        # the fibres' Ms (A/m) [985e3, thesis sec. 6.3]
//! cutoff_m = 6e-3                   # fibre images within this distance count (m)
//!                                   # [1.5 x the longest cell edge]
//! method = "tabulated"              # "exact" | "tabulated": each image's field by the exact
//!                                   # kernel or from one shared cylinder table [exact]
//! table_tolerance = 1e-6            # tabulated only: relative error of each image's field
//!                                   # and gradient, in [1e-13, 0.1) [1e-6]
//! [flow]                            # required: exactly one of the first two
//! superficial_velocity_m_s = 1e-3   # U (m/s)
//! pressure_drop_pa = 10.0           # over the whole depth (Pa): U = k dp / (mu depth)
//! force_lattice = 1e-6              # lattice body force of the Stokes solve [1e-6]
//! tau = 1.0                         # TRT relaxation time [1.0]
//! tol = 1e-7                        # steady when <u> changes by less per check [1e-7]
//! check_every = 100                 # [100]
//! max_steps = 200000                # lattice steps allowed [2e5]
//! [fluid]
//! viscosity_pa_s = 1e-3             # [1e-3]
//! density_kg_m3 = 1000.0            # for the Reynolds number [1000]
//! temperature_K = 298.0             # 0: no thermal noise [298]
//! [particles]
//! radius_m = 75e-9                  # [75e-9]
//! moment_A_m2 = 1e-17               # [thesis Table 6.1 for the radius]
//! moment_law = "fixed"              # "fixed" | "langevin" (needs domain_moment_A_m2) [fixed]
//! fed = 1000                        # particles fed at the inlet [1000]
//! [run]
//! seed = 1                          # [1]
//! dt_s = 1e-3                       # time step (s) [1e-3]
//! max_step_fraction = 0.05          # largest (sub)step / fibre radius [0.05]
//! max_steps = 1000000               # steps before the run stops with particles inside [1e6]
//! ```
//!
//! The model (stated in the summary): dilute, overdamped particles (no particle-particle
//! forces or hydrodynamics); the fibres magnetized by the applied field alone, each at its
//! own angle (Stoner–Wohlfarth with the cylinder's demagnetizing factors, thesis sec. 6.3;
//! mutual magnetization neglected, thesis sec. 5.6); the field is the superposition of the
//! fibres' images within the cutoff, each by the exact kernel or from the cylinder table (the
//! summary names the method and tolerance; `porelab bench filter` measures both);
//! the flow is the lattice Boltzmann Stokes flow through the voxelised bed, scaled to U (fibre
//! Reynolds numbers above 1 are refused).
//!
//! Outputs: `summary.json` (bed, flow with permeability and Reynolds number, counts, the
//! penetration of the whole bed and the filter coefficient with standard errors),
//! `penetration.csv` (depth_m, penetration, standard_error) and `penetration.svg`,
//! `captures.csv` (x_m, y_m, depth_m, time_s, fibre) and `captures.xyz` (extended XYZ).
//! `checkpoint.json` ([`checkpoint`]): a run killed while its particles move resumes from the
//! last checkpoint with the same `--out` (the flow is computed again, to the bit) and writes
//! bitwise the outputs of an uninterrupted run; one killed while its flow is computed starts
//! afresh.

mod checkpoint;
mod field;
mod flow;
mod outputs;
mod run;
mod schema;

pub use flow::{bed_flow, fibre_reynolds, BedFlow, LatticeOptions};
pub use run::{check_scene, run_scene};

use super::{Builtin, RunOptions};
use crate::Result;
use std::path::Path;

/// `kind = "filter"`.
pub struct Kind;

impl super::Scene for Kind {
    fn kind(&self) -> &'static str {
        "filter"
    }
    fn builtins(&self) -> Vec<Builtin> {
        vec![
            Builtin {
                name: "filter-quick",
                about: "magnetic filter: 40 packed rods, 1 T along the flow, 400 particles, 3 cells deep (~20 s)",
                toml: include_str!("../builtin/filter-quick.toml"),
            },
            Builtin {
                name: "filter-bed-200",
                about: "magnetic filter: 200 packed fibres, tabulated field, 4000 particles, 3 cells deep",
                toml: include_str!("../builtin/filter-bed-200.toml"),
            },
        ]
    }
    fn seed_key(&self) -> Option<&'static str> {
        Some("run.seed")
    }
    fn check(&self, text: &str, origin: &str) -> Result<()> {
        check_scene(text, origin)
    }
    fn run(&self, text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
        run_scene(text, origin, out, opts)
    }
}

#[cfg(test)]
mod tests;
