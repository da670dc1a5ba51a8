//! Deposition scenes (`kind = "deposition"`): the Monte-Carlo coating-layer model of seed 000.
//! Schema in README ("Deposition scenes"); every table rejects unknown keys by name.
//!
//! `schema.rs` reads the file into the engine's [`crate::deposition::Setup`] and the measure
//! options; `run.rs` runs the independent runs through the engine's driver, in parallel;
//! `outputs.rs` writes the files.

mod checkpoint;
mod outputs;
mod run;
mod schema;
#[cfg(test)]
mod tests;

pub use outputs::RunResult;
pub use run::{run_one, run_scene};
pub use schema::{parse_scene, DepositionScene};

use super::{Builtin, RunOptions};
use crate::Result;
use std::path::Path;

/// The built-in deposition scenes.
pub fn builtins() -> Vec<Builtin> {
    vec![
        Builtin {
            name: "deposition-spheres",
            about: "Deposition: 400 monodisperse spheres (r = 0.5 um), 65 % solids, 4 runs",
            toml: include_str!("../builtin/deposition-spheres.toml"),
        },
        Builtin {
            name: "deposition-platelets",
            about: "Deposition: 600 clay platelets of aspect ratio 4 (oblate), 65 % solids, 4 runs",
            toml: include_str!("../builtin/deposition-platelets.toml"),
        },
        Builtin {
            name: "deposition-blend",
            about: "Deposition: clay platelets (aspect 10) and carbonate needles (aspect 4), 50/50 by volume",
            toml: include_str!("../builtin/deposition-blend.toml"),
        },
    ]
}

/// `kind = "deposition"`.
pub struct Kind;

impl super::Scene for Kind {
    fn kind(&self) -> &'static str {
        "deposition"
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
