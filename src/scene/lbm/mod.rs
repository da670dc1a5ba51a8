//! Lattice-Boltzmann scenes (`kind = "lbm"`): steady flows of [`crate::lbm`] set up in SI.
//!
//! Schema (keys optional unless marked; defaults in brackets):
//!
//! ```toml
//! kind = "lbm"                    # required
//! title = "..."
//! flow = "channel"                # required: "channel" (plane Poiseuille; with
//!                                 # wall_velocity_m_s also Couette) | "porous-channel"
//!                                 # (Guo-Zhao Brinkman-Forchheimer medium between walls)
//!                                 # | "porous-couette" (the same medium between a resting
//!                                 # wall and one sliding at wall_velocity_m_s; walls on the
//!                                 # nodes y = 0 and H by non-equilibrium extrapolation)
//!                                 # | "sphere-array" (simple cubic, periodic)
//!                                 # | "pressure-channel" (plane channel driven through
//!                                 # its ends: inlet/outlet planes by non-equilibrium
//!                                 # extrapolation, Guo, Zheng & Shi 2002)
//!                                 # | "packing" (permeability of an extended XYZ
//!                                 # configuration, as `porelab permeability`)
//! lattice = "D3Q19"               # "D3Q15" | "D3Q19"  [D3Q19]
//! collision = "trt"               # "bgk" | "trt" (Lambda = 3/16)  [trt]
//! tau = 1.0                       # relaxation time (>= 0.505) [1.0]
//! nu_m2_s = 1e-6                  # kinematic viscosity (m^2/s) [1e-6, water]
//! density_kg_m3 = 1000.0          # density (kg/m^3) [1000]; rho_kg_m3 is read as this
//! length_m = 1e-3                 # required: channel width H, or the array period L (m)
//! cells = 32                      # required: cells across length_m (>= 4)
//! acceleration_m_s2 = 1e-3        # body force per unit mass along x (m/s^2) [0]
//! wall_velocity_m_s = 0.0         # channel: velocity of the upper wall along x (m/s) [0];
//!                                 # porous-couette: required
//! porosity = 0.5                  # porous-channel, porous-couette: eps in (0, 1]
//! permeability_m2 = 1e-9          # porous-channel, porous-couette: K (m^2)
//! forchheimer = true              # porous-channel, porous-couette: Ergun's term [true]
//! solid_fraction = 0.125          # sphere-array: phi in (0, pi/6]
//! channel_length_m = 2e-3         # pressure-channel: inlet-to-outlet distance (m), a whole
//!                                 # number of cells
//! pressure_drop_pa = 1e-3         # pressure-channel: inlet minus outlet pressure (Pa), or
//! inlet_velocity_m_s = 1e-3       # pressure-channel: peak of a parabolic inlet profile (m/s)
//!                                 # (exactly one of the two; the outlet is at the reference
//!                                 # pressure)
//! xyz = "final.xyz"               # packing, required: porelab extended XYZ (periodic box),
//!                                 # relative to the scene file's folder, or
//!                                 # "builtin:lbm-packing.xyz" (the built-in's)
//! resolution = 32                 # packing, required: cells along the box's x edge
//! unit_m = 1e-3                   # packing: the file's length unit in metres (k in m^2)
//! force_lattice = 1e-6            # packing: body force in lattice units [1e-6]
//!                                 # (packing has no length_m, cells, nu_m2_s, density_kg_m3)
//! tol = 1e-9                      # stop when <u> changes by less than this per check [1e-9]
//! check_every = 200               # steps between checks [200]
//! max_steps = 1000000             # [1e6]
//! ```
//!
//! The schema and its conversion into the engine's problems are in `schema.rs`, the runs in
//! `run.rs`, the output files in `outputs.rs`.
//!
//! Outputs: `fields.vtk` (velocity m/s, density kg/m^3, porosity, solid mask),
//! `profile.csv` for channels (y_m, u_m_s, u_exact_m_s where a closed form exists; for the
//! porous Couette flow with the Forchheimer term, the finite differences of
//! `reference::porous_couette`) and `summary.json` (tau, Mach, Re, steps, residual;
//! permeability for the sphere array). A flow refuses the keys of the other flows by name.
//! `packing` writes `permeability.txt` (what `porelab permeability` prints for one
//! resolution), `summary.json`, `fields.vtk` (lattice units; spacing in m with unit_m) and
//! `configuration.xyz` (the configuration it read).

mod checkpoint;
mod outputs;
mod run;
mod schema;
#[cfg(test)]
mod tests;

pub use run::{check_scene, run_scene};

use super::{Builtin, RunOptions};
use crate::Result;
use std::path::Path;

pub fn builtins() -> Vec<Builtin> {
    vec![
        Builtin {
            name: "lbm-channel",
            about: "LBM: plane Poiseuille flow of water in a 1 mm channel (32 cells; seconds)",
            toml: include_str!("../builtin/lbm-channel.toml"),
        },
        Builtin {
            name: "lbm-porous-channel",
            about: "LBM: Guo-Zhao porous channel, eps 0.5, Da 1e-3 (seconds)",
            toml: include_str!("../builtin/lbm-porous-channel.toml"),
        },
        Builtin {
            name: "lbm-porous-couette",
            about: "LBM: Guo-Zhao porous Couette flow, eps 0.1, Da 1e-2, Re 10 (seed 002 Fig. 6a; seconds)",
            toml: include_str!("../builtin/lbm-porous-couette.toml"),
        },
        Builtin {
            name: "lbm-packing",
            about: "LBM: permeability of a body-centred cubic sphere packing read from XYZ, 16^3 (seconds)",
            toml: include_str!("../builtin/lbm-packing.toml"),
        },
        Builtin {
            name: "lbm-pressure-channel",
            about: "LBM: plane Poiseuille flow driven by a 0.03 Pa pressure drop (inlet/outlet planes; seconds)",
            toml: include_str!("../builtin/lbm-pressure-channel.toml"),
        },
        Builtin {
            name: "lbm-sphere-array",
            about: "LBM: permeability of a simple cubic sphere array, phi 0.125, 32^3 (~1 min)",
            toml: include_str!("../builtin/lbm-sphere-array.toml"),
        },
    ]
}

/// `kind = "lbm"`.
pub struct Kind;

impl super::Scene for Kind {
    fn kind(&self) -> &'static str {
        "lbm"
    }
    fn builtins(&self) -> Vec<Builtin> {
        builtins()
    }
    fn seed_key(&self) -> Option<&'static str> {
        None
    }
    fn check(&self, text: &str, origin: &str) -> Result<()> {
        check_scene(text, origin)
    }
    fn run(&self, text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
        run_scene(text, origin, out, opts)
    }
}
