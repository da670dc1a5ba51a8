//! Tests of the deposition scene's checkpoint: a run interrupted and resumed writes the
//! uninterrupted run's outputs; a checkpoint of another scene is refused, naming the file.

use super::run::{run_scene, run_scene_limited};
use crate::deposition::{driver, Deposition, Setup};
use crate::driver::{Hooks, NoHooks};
use crate::scene::RunOptions;
use std::path::Path;

fn quiet() -> RunOptions {
    RunOptions {
        quiet: true,
        ..RunOptions::default()
    }
}

/// The built-in platelets, 80 of them in 3 runs.
fn short_scene() -> String {
    include_str!("../builtin/deposition-platelets.toml")
        .replace("particles = 600", "particles = 80")
        .replace("runs = 4", "runs = 3")
        .replace("seed = 601", "seed = 1")
}

/// The files of every run of a deposition scene with `runs` runs, without the wall times
/// (the `seconds` and `start_seconds` keys of the summaries).
fn outputs(d: &Path, runs: usize) -> Vec<(String, String)> {
    let mut v = Vec::new();
    for k in 0..runs {
        for f in [
            "final.xyz",
            "history.csv",
            "porosity_profile.csv",
            "summary.json",
        ] {
            let f = format!("run-{k:03}/{f}");
            let text = std::fs::read_to_string(d.join(&f)).unwrap();
            let kept: Vec<&str> = text.lines().filter(|l| !l.contains("seconds\"")).collect();
            v.push((f, kept.join("\n")));
        }
    }
    v
}

/// A run stopped after 25 sweeps of every run and resumed from its checkpoint writes bitwise
/// the outputs of the uninterrupted run (all but the wall times).
#[test]
fn interrupted_run_resumes_to_the_same_result() {
    let base = std::env::temp_dir().join(format!("porelab-dep-resume-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    let (whole, killed) = (base.join("whole"), base.join("killed"));
    let text = short_scene();
    run_scene(&text, "test", &whole, &quiet()).unwrap();
    run_scene_limited(&text, "test", &killed, &quiet(), Some(25)).unwrap();
    assert!(killed.join("checkpoint.json").exists());
    assert!(!killed.join("summary.json").exists());
    run_scene(&text, "test", &killed, &quiet()).unwrap();
    assert!(!killed.join("checkpoint.json").exists());
    let (a, b) = (outputs(&whole, 3), outputs(&killed, 3));
    for ((f, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{f} differs");
    }
    // the resume had work to do: every run went past the stop
    let history = std::fs::read_to_string(whole.join("run-000/history.csv")).unwrap();
    assert!(history.lines().count() > 27, "{history}");
    // a checkpoint of another scene is refused, naming the file
    run_scene_limited(&text, "test", &killed, &quiet(), Some(5)).unwrap();
    crate::scene::assert_other_scene_refused(|t| run_scene(t, "test", &killed, &quiet()), &text);
    let _ = std::fs::remove_dir_all(&base);
}

// The engine's own save and restore (`deposition::checkpoint`), on a setup parsed from a
// built-in: a stopped run restored from its JSON state ends bitwise as the uninterrupted one.

/// Stops a run after `n` sweeps.
struct StopAfter(u64);

impl Hooks<Deposition> for StopAfter {
    fn stop_requested(&mut self, d: &Deposition) -> bool {
        d.outcome().sweeps >= self.0
    }
}

/// 60 platelets (Perram-Wertheim pairs, rotations) with a short window.
fn engine_setup() -> Setup {
    let text = include_str!("../builtin/deposition-platelets.toml")
        .replace("particles = 600", "particles = 60");
    super::parse_scene(&text, "t").unwrap().setup
}

/// A run stopped after 30 sweeps, saved through JSON and restored from the setup ends in
/// bitwise the state of the uninterrupted run (prefilter counts and history included).
#[test]
fn restored_run_continues_bitwise() {
    let setup = engine_setup();
    let mut whole = Deposition::new(&setup, 1).unwrap();
    driver::run(&mut whole, &mut NoHooks).unwrap();
    let mut first = Deposition::new(&setup, 1).unwrap();
    driver::run(&mut first, &mut StopAfter(30)).unwrap();
    assert!(!first.is_done() && whole.outcome().sweeps > 40);
    let text = serde_json::to_string(&first.save_state()).unwrap();
    let mut second = Deposition::restore(&setup, 1, &serde_json::from_str(&text).unwrap()).unwrap();
    driver::run(&mut second, &mut NoHooks).unwrap();
    assert!(whole.outcome().prefilters.perram_wertheim > 0);
    assert_eq!(whole.save_state(), second.save_state());
}

#[test]
fn a_foreign_state_is_refused() {
    let setup = engine_setup();
    let d = Deposition::new(&setup, 0).unwrap();
    let e = Deposition::restore(&setup, 1, &d.save_state())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("random stream"), "{e}");
    let mut s = d.save_state();
    s.position.pop();
    let e = Deposition::restore(&setup, 0, &s)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("`position`"), "{e}");
    let mut s = d.save_state();
    s.cell_members[0].push(0);
    let e = Deposition::restore(&setup, 0, &s)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("cell list"), "{e}");
}

/// 150 spheres under the accepted-move rest rule with isotropic directions (both not the
/// seed's): the run ends by the rule, the summary says which rules ran and holds the supported
/// fraction; both rest rules at once are refused, naming the keys.
#[test]
fn sphere_scene_with_the_rest_rule_reports_its_supported_fraction() {
    let text = "kind = \"deposition\"\nseed = 3\nruns = 1\n[film]\nparticles = 150\n\
                box_side_m = 5e-6\nsolids_percent = 65\n[[species]]\nname = \"sphere\"\n\
                semi_axes_m = [0.5e-6, 0.5e-6, 0.5e-6]\n[deposition]\nstop_window = 100\n\
                stop_accepted_rate = 0.01\nisotropic_directions = true\nmax_sweeps = 100000\n";
    let d = std::env::temp_dir().join(format!("porelab-dep-rest-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    run_scene(text, "test", &d, &quiet()).unwrap();
    let read = |f: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(d.join(f)).unwrap()).unwrap()
    };
    let run = read("run-000/summary.json");
    assert_eq!(run["converged"], true);
    let s = run["measures"]["supported_fraction"].as_f64().unwrap();
    assert!(s > 0.0 && s <= 1.0, "{s}");
    let terms = read("summary.json")["active_terms"].to_string();
    assert!(
        terms.contains("isotropic move directions") && terms.contains("accepted-move rest rule")
    );
    let both = text.replace("max_sweeps", "stop_supported_fraction = 0.9\nmax_sweeps");
    let e = run_scene(&both, "test", &d, &quiet())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("stop_accepted_rate") && e.contains("stop_supported_fraction"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&d);
}
