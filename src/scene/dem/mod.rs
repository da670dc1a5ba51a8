//! DEM scenes (`kind = "dem"`): soft spheres settled, compressed or dragged into a bed by the
//! engine of [`crate::dem`]. SI units; z is the vertical (the seed's x).
//!
//! Schema (defaults in brackets):
//!
//! ```toml
//! kind = "dem"
//! title = "..."
//! seed = 1                           # ChaCha8 seed of the sizes and the dispersion [1]
//! [particles]
//! n = 300                            # number of spheres (required, >= 1)
//! density_kg_m3 = 2500.0             # [2500]
//! size = "mono"                      # "mono" | "lognormal" | "table" [mono]
//! diameter_m = 4e-4                  # mono (required for mono)
//! median_diameter_m = 4e-4           # lognormal: median, sigma of ln d, clipped to [min, max]
//! sigma_ln = 0.2
//! min_diameter_m = 2e-4
//! max_diameter_m = 8e-4
//! diameters_m = [3e-4, 4e-4]         # table: diameters and their number fractions
//! number_fractions = [0.5, 0.5]
//! [box]
//! lx_m = 1.6e-3                      # periodic lengths (required)
//! ly_m = 1.6e-3
//! height_m = 1.6e-2                  # top wall height; or give `porosity` instead
//! porosity = 0.75                    # initial porosity of the dispersion (sets the height)
//! [contact]
//! young_pa = 1e7                     # laws that read moduli (Hertz, Mindlin, Zhou): required
//! poisson = 0.3                      # [0.3]
//! wall_young_pa = 1e7                # [young_pa]
//! wall_poisson = 0.3                 # [poisson]
//! # the law: a preset ...
//! model = "hertz-mindlin"            # "hertz-mindlin" | "hertz" (frictionless) | "linear" | "zhou2002"
//! k_n_n_per_m = 1e3                  # linear (required there)
//! kt_over_kn = 0.2857                # linear tangential spring [2/7]
//! restitution = 0.5                  # normal damping by restitution, (0, 1] [0.5]
//! friction = 0.5                     # Coulomb mu (hertz-mindlin, linear, zhou2002) [0.5]
//! tangential_damping_ratio = 1.0     # eta_t / eta_n (hertz-mindlin, linear) [1]
//! c_n = 0.3                          # zhou2002: normal damping coefficient [0.3]
//! c_t = 0.3                          # zhou2002: tangential damping coefficient [c_n]
//! # ... or three sub-models chosen separately (instead of `model` and its coefficients)
//! normal = { model = "hertz" }       # "hertz" | "linear" (k_n_n_per_m)
//! damping = { model = "restitution", restitution = 0.5 }  # | "zhou2002" (c_n) | "none"
//! tangential = { model = "mindlin", friction = 0.3 }      # damping_ratio [1];
//!                                    # | "linear" (friction, kt_over_kn [2/7], damping_ratio [1])
//!                                    # | "zhou2002" (friction, c_t) | "none"
//! [drivers]
//! gravity_m_s2 = 9.81                # along -z [0]
//! fluid_density_kg_m3 = 0.0          # buoyancy [0]
//! viscosity_pa_s = 1e-3              # uniform Stokes drag on (with fluid_velocity_m_s)
//! fluid_velocity_m_s = [0, 0, -0.2]  # U_F [0, 0, 0]
//! top_pressure_pa = 184.0            # pressure-controlled top wall on
//! top_speed_max_m_s = 0.05           # its speed limit [0.05]
//! [run]
//! dt_s = 1e-6                        # [automatic: min(0.2 t_Rayleigh, t_contact / 50)]
//! skin_m = 1.2e-4                    # [0.3 d_min]
//! max_time_s = 1.0                   # guard on simulated time [1]
//! check_every_s = 0.01               # stop test and history interval [0.01]
//! ke_fraction = 1e-6                 # stop when KE < ke_fraction * peak KE ... [1e-6]
//!                                    # (KE without the spin of spheres touching nothing)
//! height_tol_over_d = 1e-3           # ... and the bed top moved < this * <d> since last check
//! profile_bins = 60                  # slabs of the porosity profile [60]
//! trajectory_every_s = 0.05          # a trajectory frame at this interval [none]
//! rdf_max_over_d = 3.0               # g(r) range in <d> [3, or half the narrower side]
//! rdf_bins = 150                     # [150]
//! pore_voxels_per_d = 10.0           # pore-size grid resolution, 0: none [10]
//! ```
//!
//! A key that the chosen size or contact law does not read is refused, never ignored; the old
//! spellings `rho_kg_m3` and `viscosity_Pa_s` are read under their new names
//! ([`super::keys`]). The schema and its reading into the engine's setup are in `schema.rs`,
//! the run (the engine's driver with this scene's hooks) in `run.rs`, the output files in
//! `outputs.rs`.
//!
//! Outputs (README, "Output formats"): `final.xyz`, `trajectory/frame_NNNNNN.xyz`,
//! `profile.csv`, `history.csv`, `rdf.csv`, `pore_sizes.csv`, `summary.json`, and while running
//! `checkpoint.json`, from which an interrupted run resumes bitwise.

mod outputs;
mod run;
mod schema;

pub use outputs::{bed_pore_sizes, bed_rdf, pore_sizes, summarize, DemSummary, PoreSummary};
pub use run::{build, run_scene};
pub use schema::{parse_scene, DemFile, DemScene, OutputSettings, ZHOU_C_N_DEFAULT};

use super::{Builtin, RunOptions};
use crate::Result;
use std::path::Path;

/// The built-in DEM scenes.
pub fn builtins() -> Vec<Builtin> {
    vec![
        Builtin {
            name: "dem-small",
            about:
                "DEM: 300 spheres d = 400 um settling under gravity, seed 002 proportions (seconds)",
            toml: include_str!("../builtin/dem-small.toml"),
        },
        Builtin {
            name: "dem-seed-gravity",
            about: "DEM: seed 002's 2014 spheres d = 400 um in 3 x 3 x 30 mm, gravity-driven",
            toml: include_str!("../builtin/dem-seed-gravity.toml"),
        },
        Builtin {
            name: "dem-seed-compression",
            about: "DEM: seed 002's 2014 spheres, pressure-controlled top wall, no gravity",
            toml: include_str!("../builtin/dem-seed-compression.toml"),
        },
        Builtin {
            name: "dem-seed-drag",
            about: "DEM: seed 002's 2014 spheres, uniform Stokes drag towards the floor",
            toml: include_str!("../builtin/dem-seed-drag.toml"),
        },
    ]
}

/// `kind = "dem"`.
pub struct Kind;

impl super::Scene for Kind {
    fn kind(&self) -> &'static str {
        "dem"
    }
    fn builtins(&self) -> Vec<Builtin> {
        builtins()
    }
    fn seed_key(&self) -> Option<&'static str> {
        Some("seed")
    }
    fn check(&self, text: &str, origin: &str) -> Result<()> {
        parse_scene(text, origin).map(|_| ())
    }
    fn run(&self, text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
        run_scene(text, origin, out, opts)
    }
}

#[cfg(test)]
mod tests;
