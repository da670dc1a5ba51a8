//! Tests of packing scenes: parsing, resuming, outputs.

use super::outputs::read_checkpoint;
use super::run::run_scene_limited;
use super::*;
use crate::analysis;
use crate::io::xyz;
use crate::packing::{ParticleShapes, Setup};
use crate::scene::RunOptions;

/// 40 rods (L/D 0.5) in a periodic box, a short schedule (also a filter bed in its tests).
pub(crate) const SMALL: &str = r#"
kind = "packing"
title = "test"
[particles]
shape = "spherocylinder"
n = 40
length_over_diameter = 0.5
[mcm]
seed = 11
delta_v_per_particle = 0.05
halvings = 2
tries_per_particle = 50.0
[final_stage]
delta_v_per_particle = 0.005
halvings = 1
[analysis]
gr_bins = 20
s4_trials = 50
"#;

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("porelab-scene-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// The summary.json of a finished run in `dir`.
fn summary_of(dir: &std::path::Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap()
}

fn quiet() -> RunOptions {
    RunOptions {
        quiet: true,
        ..Default::default()
    }
}

/// A run whose final stage ends on its budget resumes, one step at a time, to the same
/// result: the checkpoint carries the stage's moves so far.
#[test]
fn budgeted_stage_resumes_to_the_same_result() {
    let text = SMALL.replace(
        "halvings = 1\n[analysis]",
        "halvings = 6\nstage_budget_per_particle = 120.0\n[analysis]",
    );
    assert_ne!(text, SMALL);
    let (a, b) = (tmp("budget-full"), tmp("budget-resumed"));
    run_scene(&text, "test", &a, &quiet()).unwrap();
    let mut calls = 0;
    while !b.join("final.xyz").exists() {
        run_scene_limited(&text, "test", &b, &quiet(), Some(1)).unwrap();
        calls += 1;
        assert!(calls < 10_000);
    }
    assert!(
        std::fs::read(a.join("final.xyz")).unwrap() == std::fs::read(b.join("final.xyz")).unwrap(),
        "final.xyz differs between the full and the resumed run"
    );
    let sa = summary_of(&a);
    let sb = summary_of(&b);
    assert_eq!(sa["stage_budget_spent"], serde_json::Value::Bool(true));
    for k in ["total_tries", "failed_steps", "stage_budget_spent"] {
        assert_eq!(sa[k], sb[k], "{k}");
    }
}

#[test]
fn interrupted_run_resumes_to_the_same_result() {
    let (a, b) = (tmp("full"), tmp("resumed"));
    run_scene(SMALL, "test", &a, &quiet()).unwrap();
    // Interrupt twice (after 7 and 5 more steps), then finish. The interrupted parts
    // checkpoint rarely (every 1e9 s): the stop itself must save the state reached.
    let rare = RunOptions {
        checkpoint_every_seconds: Some(1e9),
        ..quiet()
    };
    run_scene_limited(SMALL, "test", &b, &rare, Some(7)).unwrap();
    assert!(b.join("checkpoint.json").exists() && !b.join("final.xyz").exists());
    let scene = parse_scene(SMALL, "test").unwrap();
    let (state, _) = read_checkpoint(&b.join("checkpoint.json"), &scene).unwrap();
    assert_eq!(state.history.len() + state.failed_steps, 7);
    run_scene_limited(SMALL, "test", &b, &rare, Some(5)).unwrap();
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        let o = RunOptions {
            checkpoint_every_seconds: Some(bad),
            ..quiet()
        };
        let e = run_scene(SMALL, "test", &b, &o).unwrap_err().to_string();
        assert!(e.contains("checkpoint interval"), "{e}");
    }
    run_scene(SMALL, "test", &b, &rare).unwrap();
    for f in ["final.xyz", "phi_history.csv", "gr.csv"] {
        let (x, y) = (
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
        );
        assert!(x == y, "{f} differs between the full and the resumed run");
    }
    let sa = summary_of(&a);
    let sb = summary_of(&b);
    for k in [
        "packing_fraction",
        "compression_steps",
        "total_tries",
        "cubatic_s4",
    ] {
        assert_eq!(sa[k], sb[k], "{k}");
    }
    // The outputs describe an overlap-free packing: check the XYZ file independently.
    let (cell, parts) = xyz::parse(
        &std::fs::read_to_string(a.join("final.xyz")).unwrap(),
        "final",
    )
    .unwrap();
    let l = cell.lengths[0];
    let pos: Vec<_> = parts.iter().map(|p| p.position).collect();
    let ori: Vec<_> = parts.iter().map(|p| p.orientation).collect();
    let mono = ParticleShapes::monodisperse(pos.len(), 0.5);
    let v = analysis::Rods {
        box_length: l,
        wall_diameter: None,
        wedge: None,
        shapes: &mono.shapes,
        species: &mono.species,
        positions: &pos,
        orientations: &ori,
    };
    analysis::check_no_overlap(&v, 1e-4 * (1.0 + 1e-6)).unwrap();
    assert_eq!(
        sa["packing_fraction"].as_f64().unwrap(),
        analysis::packing_fraction(&v).unwrap()
    );
    // The history has one row per accepted step, increasing packing fraction.
    let hist = std::fs::read_to_string(a.join("phi_history.csv")).unwrap();
    let phis: Vec<f64> = hist
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(2).unwrap().parse().unwrap())
        .collect();
    assert_eq!(phis.len() as u64, sa["compression_steps"].as_u64().unwrap());
    assert!(phis.windows(2).all(|w| w[1] > w[0]));
    // One worker thread gives the same outputs as the default pool.
    let c = tmp("one-thread");
    let one = RunOptions {
        quiet: true,
        threads: Some(1),
        ..Default::default()
    };
    run_scene(SMALL, "test", &c, &one).unwrap();
    for f in [
        "final.xyz",
        "phi_history.csv",
        "gr.csv",
        "orientation_histogram.csv",
    ] {
        assert!(
            std::fs::read(a.join(f)).unwrap() == std::fs::read(c.join(f)).unwrap(),
            "{f} depends on the thread count"
        );
    }
    let _ = std::fs::remove_dir_all(&c);
    // A changed scene refuses the old checkpoint, naming it.
    let changed = SMALL.replace("seed = 11", "seed = 12");
    let e = run_scene_limited(&changed, "test", &b, &quiet(), Some(1)).unwrap_err();
    assert!(e.to_string().contains("different scene"), "{e}");
    let _ = std::fs::remove_dir_all(&a);
    let _ = std::fs::remove_dir_all(&b);
}

#[test]
fn misspelt_and_bad_keys_are_rejected_by_name() {
    let e = parse_scene(&SMALL.replace("halvings = 2", "halvings_ = 2"), "t").unwrap_err();
    assert!(e.to_string().contains("halvings_"), "{e}");
    let e = parse_scene(&SMALL.replace("n = 40", "n = 1"), "t").unwrap_err();
    assert!(e.to_string().contains("n = 1"), "{e}");
    let e = parse_scene(&SMALL.replace("\"spherocylinder\"", "\"cube\""), "t").unwrap_err();
    assert!(e.to_string().contains("cube"), "{e}");
    let e = parse_scene(&SMALL.replace("length_over_diameter = 0.5", ""), "t").unwrap_err();
    assert!(e.to_string().contains("length_over_diameter"), "{e}");
    let e = parse_scene(
        &SMALL.replace(
            "[final_stage]\ndelta_v_per_particle = 0.005",
            "[final_stage]\ndelta_v_per_particle = -1",
        ),
        "t",
    )
    .unwrap_err();
    assert!(
        e.to_string().contains("final stage") && e.to_string().contains("delta_v"),
        "{e}"
    );
    let e = parse_scene(&format!("{SMALL}\n[box]\nx = 1\n"), "t").unwrap_err();
    assert!(e.to_string().contains("box"), "{e}");
}

const MIXTURE: &str = r#"
kind = "packing"
[[particles.species]]
shape = "sphere"
n = 30
diameter = 1.4
[[particles.species]]
shape = "sphere"
n = 50
[particles.species.polydisperse]
distribution = "uniform"
min = 0.8
max = 1.2
seed = 3
[mcm]
seed = 2
"#;

/// Species tables: a monodisperse block and a polydisperse one (one table entry per
/// particle, diameters inside [min, max]); misspelt or misplaced keys are named.
#[test]
fn species_tables_parse_and_bad_keys_are_named() {
    let sc = parse_scene(MIXTURE, "t").unwrap();
    let p = sc.setup.particles();
    assert_eq!((sc.setup.n, p.n(), p.shapes.len()), (80, 80, 51));
    assert_eq!(p.counts()[0], 30);
    for s in &p.shapes[1..] {
        let (r, _) = analysis::rod_parameters(s).unwrap();
        assert!((0.4..=0.6).contains(&r), "{r}");
    }
    assert_eq!(sc.analysis.rattler_min_contacts, 4);
    let bad = |from: &str, to: &str, want: &str| {
        let e = parse_scene(&MIXTURE.replacen(from, to, 1), "t").unwrap_err();
        assert!(e.to_string().contains(want), "{e}");
    };
    bad("diameter = 1.4", "diametre = 1.4", "diametre");
    bad("diameter = 1.4", "exponent = 3.0", "exponent");
    bad(r#""uniform""#, r#""gaussian""#, "gaussian");
    bad("min = 0.8", "sigma = 0.2", "sigma");
    bad(
        "[[particles.species]]",
        "[particles]\nn = 5\n[[particles.species]]",
        "particles.n",
    );
    bad(r#"shape = "sphere""#, r#"shape = "cube""#, "cube");
    let sb = parse_scene(
        r#"
kind = "packing"
[[particles.species]]
shape = "superball"
n = 50
exponent = 3.0
[mcm]
scheme = "original"
"#,
        "t",
    )
    .unwrap_err();
    assert!(sb.to_string().contains("revised"), "{sb}");
}

/// The built-in `packing-spheres` is the schedule of case 512 and the benchmark.
#[test]
fn builtin_spheres_is_the_jamming_schedule() {
    let b = builtins()
        .into_iter()
        .find(|b| b.name == "packing-spheres")
        .unwrap();
    let got = parse_scene(b.toml, b.name).unwrap().setup;
    let want = Setup::jammed_spheres(1000, 1);
    assert_eq!(format!("{got:?}"), format!("{want:?}"));
}

#[test]
fn builtins_parse() {
    for b in builtins() {
        parse_scene(b.toml, b.name).unwrap();
    }
}
