//! Packing scenes (`kind = "packing"`): the mechanical contraction method of [`crate::packing`]
//! run from a TOML file, with outputs and checkpoints in the output folder.
//!
//! Schema (every table and key optional unless marked; defaults in brackets; reduced units:
//! particle diameter 1):
//!
//! ```toml
//! kind = "packing"                 # required
//! title = "..."                    # free text, copied to the summary
//! [particles]
//! shape = "sphere"                 # "sphere" | "spherocylinder"  [sphere]
//! n = 1000                         # number of particles (>= 2)     [1000]
//! length_over_diameter = 0.0       # L/D of the cylinder between the caps (spherocylinder, > 0)
//! [container]
//! shape = "periodic"               # "periodic" (cubic box) | "cylinder" (hard wall, periodic
//!                                  # along its axis z; sec. 2.2.4) | "wedge" (three hard
//!                                  # planes, periodic along z; eq. 2.12-2.13)  [periodic]
//! diameter = 6.0                   # cylinder diameter D_cyl in D (> 1), cylinder only
//! length = 10.0                    # wedge length l_w along x (D), wedge only
//! angle_deg = 30.0                 # wedge angle alpha (degrees), wedge only
//!                                  # (any shape, superquadrics included, packs in any container)
//! [mcm]
//! seed = 1                         # ChaCha8 seed of the random start [1]
//! scheme = "original"              # "original" (eq. 2.4-2.10) | "revised" (eq. 3.2-3.13) |
//!                                  # "relax" (collective FIRE descent, packing::relax)
//! phi0 = 0.05                      # start packing fraction, (0, 0.2]
//! delta_v_per_particle = 0.01      # Delta V / N in D^3
//! halvings = 6                     # halvings of Delta V after failed steps
//! tries_per_particle = 200.0       # particle moves allowed per compression step / N
//! stage_budget_per_particle = 2e4  # moves allowed over the whole stage / N [unbounded]
//! overlap_tol = 1e-4               # overlaps below this count as removed (sec. 2.2.6)
//! beta = 0.5                       # original scheme, eq. 2.10
//! dt = 0.1                         # revised scheme, eq. 3.9 / 3.12; relax: FIRE's initial step
//! energy = 1.0                     # revised scheme, c of eq. 3.4
//! max_steps = 1000000              # safety limit on accepted steps
//! [final_stage]                    # optional second stage from where the first stopped
//! scheme = "revised"               # [as in [mcm]]
//! delta_v_per_particle = 1e-4      # required in the table
//! halvings = 10                    # required in the table
//! tries_per_particle = 1000.0      # [as in [mcm]]
//! stage_budget_per_particle = 2.5e4 # [unbounded; not inherited from [mcm]]
//! beta = 0.5                       # [as in [mcm]]
//! dt = 0.1                         # [as in [mcm]]
//! [analysis]
//! contact_cutoffs = [1e-8, 1e-7, 1e-6, 1e-5]   # gap cut-offs for the extrapolation (sec. 2.2.5)
//! rattler_min_contacts = 4         # fewer contacts: rattler [4 spheres, 5 spherocylinders]
//! gr_r_max = 3.0                   # g(r) range (<= half the box) [min(3, L/2)]
//! gr_bins = 150                    # [150]
//! s4_trials = 2000                 # trial directions of the S4 maximisation (eq. 4.17)
//! ```
//!
//! The scene's schema (a serde mirror of [`crate::packing::Setup`]) and its checks are in
//! `schema.rs`; `run.rs` builds the engine ([`crate::packing::Mcm`]) and runs its driver with
//! this scene's progress, checkpoint and stop hooks; `outputs.rs` writes the files and the
//! checkpoint.
//!
//! Outputs in the output folder (README, "Output formats"): `final.xyz` (extended XYZ),
//! `summary.json`, `phi_history.csv`, `gr.csv`, and `checkpoint.json`, written atomically after
//! every compression step. When `checkpoint.json` is present, `porelab run` resumes from it
//! (after checking that it was written by the same scene) and reaches bitwise the same
//! configuration as an uninterrupted run: the MCM draws no random numbers after the start.

mod outputs;
mod run;
mod schema;

/// `kind = "packing"`.
pub struct Kind;

impl super::Scene for Kind {
    fn kind(&self) -> &'static str {
        "packing"
    }
    fn builtins(&self) -> Vec<Builtin> {
        builtins()
    }
    fn seed_key(&self) -> Option<&'static str> {
        Some("mcm.seed")
    }
    fn check(&self, text: &str, origin: &str) -> Result<()> {
        parse_scene(text, origin).map(|_| ())
    }
    fn run(&self, text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
        run_scene(text, origin, out, opts)
    }
}

#[cfg(test)]
pub(crate) mod tests;

pub(crate) use run::run_for_configuration;
pub use run::run_scene;
pub use schema::{parse_scene, PackingScene};

use super::{Builtin, RunOptions};
use crate::Result;
use std::path::Path;

/// The built-in packing scenes.
pub fn builtins() -> Vec<Builtin> {
    vec![
        Builtin {
            name: "packing-spheres",
            about: "MCM: 1000 spheres in a periodic box (compacting + settling stage; ~1 min)",
            toml: include_str!("../builtin/packing-spheres.toml"),
        },
        Builtin {
            name: "packing-cylinder",
            about: "MCM: 500 spheres in a hard cylinder D_cyl = 6 (virtual-particle wall)",
            toml: include_str!("../builtin/packing-cylinder.toml"),
        },
        Builtin {
            name: "packing-wedge",
            about: "MCM: 300 spherocylinders L/D = 1 in a hard 30-degree wedge (virtual-particle walls)",
            toml: include_str!("../builtin/packing-wedge.toml"),
        },
        Builtin {
            name: "packing-superballs",
            about: "MCM: 50 superballs gamma = 3 in a periodic box (revised scheme, contact solver)",
            toml: include_str!("../builtin/packing-superballs.toml"),
        },
        Builtin {
            name: "packing-superballs-cylinder",
            about: "MCM: 50 superballs gamma = 3 in a hard cylinder D_cyl = 4 (support-function wall)",
            toml: include_str!("../builtin/packing-superballs-cylinder.toml"),
        },
        Builtin {
            name: "packing-spherocylinders",
            about: "MCM: 500 spherocylinders L/D = 0.4 in a periodic box (original scheme)",
            toml: include_str!("../builtin/packing-spherocylinders.toml"),
        },
    ]
}
