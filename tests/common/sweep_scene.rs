//! The tiny sweep shared by tests/sweep.rs and tests/slurm.rs (included with `#[path]`; not a
//! test target): 2 points (20 and 30 spheres) x 3 runs of a packing scene, each job well under
//! a second.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The base scene: 20 spheres (the sweep benchmark's scene).
pub const BASE_SCENE: &str = porelab::bench::sweep::TINY_PACKING;

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

/// Runs `cmd` and asserts that it succeeded; returns its stdout and stderr.
pub fn ok(cmd: &mut Command) -> (String, String) {
    let out = cmd.output().expect("the command starts");
    let (o, e) = (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    );
    assert!(out.status.success(), "{cmd:?} failed: {o}\n{e}");
    (o, e)
}

/// `porelab sweep plan SWEEP --out DIR`, which must succeed.
pub fn plan(sweep: &Path, dir: &Path) {
    ok(porelab()
        .args(["sweep", "plan"])
        .arg(sweep)
        .arg("--out")
        .arg(dir));
}
