//! Tests of the filter scene: its built-ins check, bad values are refused by key, and a
//! small run writes its files with the counts adding up.

use super::*;
use crate::scene::Scene as _;

fn builtin() -> &'static str {
    include_str!("../builtin/filter-quick.toml")
}

#[test]
fn builtins_check() {
    for b in Kind.builtins() {
        check_scene(b.toml, &format!("builtin:{}", b.name)).unwrap();
    }
}

#[test]
fn bad_values_are_refused_by_key_and_line() {
    for (from, to, needle) in [
        (
            "fibre_radius_m = 2e-4",
            "fibre_radius_m = -2e-4",
            "bed.fibre_radius_m",
        ),
        ("resolution = 24", "resolution = 2", "bed.resolution"),
        ("fed = 400", "fed = 0", "particles.fed"),
        ("dt_s = 0.02", "dt_s = 0.0", "run.dt_s"),
        (
            "superficial_velocity_m_s = 1e-3",
            "superficial_velocity_m_s = 10.0",
            "Reynolds",
        ),
        (
            "superficial_velocity_m_s = 1e-3",
            "pressure_drop_pa = 1.0\nsuperficial_velocity_m_s = 1e-3",
            "exactly one",
        ),
        (
            "direction = [0.0, 0.0, 1.0]",
            "direction = [0.0, 0.0, 0.0]",
            "field.direction",
        ),
        (
            "temperature_K = 298.0",
            "temperature_K = -1.0",
            "fluid.temperature_K",
        ),
        ("builtin:filter-rods.xyz", "builtin:none.xyz", "bed.xyz"),
    ] {
        let text = builtin().replace(from, to);
        assert_ne!(text, builtin(), "{from}");
        let e = check_scene(&text, "s.toml").unwrap_err().to_string();
        assert!(e.contains(needle) && e.contains("s.toml"), "{to}: {e}");
    }
    let e = check_scene(&builtin().replace("fed = 400", "fed = 0"), "s.toml")
        .unwrap_err()
        .to_string();
    let line = builtin()
        .lines()
        .position(|l| l.trim_start().starts_with("fed = 400"))
        .map(|i| i + 1)
        .unwrap();
    assert!(e.contains(&format!("(line {line})")), "{e}");
}

/// A short run of the built-in (fewer particles, one cell): every file is written and the
/// counts in the summary add up.
#[test]
fn a_small_run_writes_its_files() {
    let dir = std::env::temp_dir().join(format!("porelab-filter-scene-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let text = builtin()
        .replace("fed = 400", "fed = 20")
        .replace("cells_deep = 3", "cells_deep = 1")
        .replace("resolution = 24", "resolution = 12");
    let opts = RunOptions {
        quiet: true,
        ..Default::default()
    };
    run_scene(&text, "builtin:t", &dir, &opts).unwrap();
    for f in [
        "summary.json",
        "penetration.csv",
        "penetration.svg",
        "captures.csv",
        "captures.xyz",
    ] {
        assert!(dir.join(f).exists(), "{f}");
    }
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    let n = |k: &str| s[k].as_u64().unwrap();
    assert_eq!(n("fed"), 20);
    assert_eq!(n("captured") + n("passed") + n("inside"), 20);
    let _ = std::fs::remove_dir_all(&dir);
}
