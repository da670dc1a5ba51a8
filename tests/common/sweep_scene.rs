//! The tiny sweep shared by tests/sweep.rs and tests/slurm.rs (included with `#[path]`; not a
//! test target): 2 points (20 and 30 spheres) x 3 runs of a packing scene, each job well under
//! a second.

use std::path::{Path, PathBuf};
use std::process::Command;

pub const BASE_SCENE: &str = r#"kind = "packing"
title = "sweep test"
[particles]
shape = "sphere"
n = 20
[mcm]
delta_v_per_particle = 0.05
halvings = 2
tries_per_particle = 50.0
[analysis]
gr_bins = 20
s4_trials = 50
"#;

pub const SWEEP: &str = r#"title = "2 sizes x 3 runs"
scene = "base.toml"
runs_per_point = 3
base_seed = 5
[vary]
"particles.n" = [20, 30]
"#;

/// The porelab binary under test.
pub fn porelab() -> Command {
    Command::new(env!("CARGO_BIN_EXE_porelab"))
}

/// An empty folder under cargo's test temp dir.
pub fn fresh_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("sweep-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes the base scene and the sweep file into `root`; returns the sweep file's path.
pub fn write_sweep(root: &Path) -> PathBuf {
    std::fs::write(root.join("base.toml"), BASE_SCENE).unwrap();
    let s = root.join("sweep.toml");
    std::fs::write(&s, SWEEP).unwrap();
    s
}
