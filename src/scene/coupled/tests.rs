//! Tests of the coupled engine through its scenes: refusals before and during a run, the
//! built-ins' start, and a checkpoint restored bitwise.

use super::run::run_scene_limited;
use super::{build, builtins, parse_scene, run_scene, RunOptions};
use crate::coupled::Coupled;
use crate::Result;
use std::path::Path;

fn quick(edit: impl Fn(String) -> String) -> Result<Coupled> {
    let text = edit(include_str!("../builtin/coupled-quick.toml").to_string());
    build(&parse_scene(&text, "test")?)
}

/// A driving too large for the weakly compressible fluid is refused before the run,
/// naming the key, the value and the rule (it used to stop at the first non-finite
/// density); the built-ins pass.
#[test]
fn too_strong_a_driving_is_refused_up_front() {
    let e = quick(|t| {
        t.replace(
            "pressure_gradient_pa_m = [0.0, 0.0, 500.0]",
            "pressure_gradient_pa_m = [0.0, 0.0, 5e5]",
        )
    })
    .err()
    .expect("refused")
    .to_string();
    assert!(
        e.contains("fluid.pressure_gradient_pa_m") && e.contains("Mach") && e.contains("500000"),
        "{e}"
    );
    // Mach within its limit (3000 Pa/m: Mach ~0.13) but the free fluid's density
    // variation beyond 0.5 (~0.76)
    let e = quick(|t| {
        t.replace(
            "pressure_gradient_pa_m = [0.0, 0.0, 500.0]",
            "pressure_gradient_pa_m = [0.0, 0.0, 3000.0]",
        )
    })
    .err()
    .expect("refused")
    .to_string();
    assert!(
        e.contains("fluid.pressure_gradient_pa_m") && e.contains("density"),
        "{e}"
    );
    for b in builtins() {
        build(&parse_scene(b.toml, b.name).unwrap()).unwrap();
    }
}

/// A coupling interval too long for the motion (a particle moving more than
/// max_move_cells of a cell per coupling step) is refused with the reason, never NaN; so
/// is a drag relaxation beyond the limit.
#[test]
fn too_long_a_coupling_step_is_refused() {
    let mut c = quick(|t| {
        t.replace(
            "max_relaxation = 1.0",
            "max_relaxation = 1.0\nmax_move_cells = 0.001",
        )
    })
    .unwrap();
    let mut err = None;
    for _ in 0..200 {
        if let Err(e) = c.step() {
            err = Some(e.to_string());
            break;
        }
    }
    let e = err.expect("a refusal");
    assert!(e.contains("coupling.max_move_cells = 0.001"), "{e}");
    // a drag relaxation beyond the limit is refused at the first step
    let mut c = quick(|t| {
        // (a gentler gradient: dt_LBM grows 178-fold with tau = 0.7)
        t.replace("tau = 0.515", "tau = 0.7")
            .replace(
                "dem_steps_per_lbm_step = 200",
                "dem_steps_per_lbm_step = 3000",
            )
            .replace(
                "pressure_gradient_pa_m = [0.0, 0.0, 500.0]",
                "pressure_gradient_pa_m = [0.0, 0.0, 1.0]",
            )
    })
    .unwrap();
    let e = c.step().err().expect("refused").to_string();
    assert!(e.contains("max_relaxation"), "{e}");
}

/// Cells packed far beyond any real porosity (eps -> 0) stay finite: the floor eps_min
/// and Guo–Zhao's implicit drag keep the fluid stable, and the state is refused or finite.
#[test]
fn porosity_near_zero_stays_finite() {
    let mut c = quick(|t| {
        t.replace("eps_min = 0.1", "eps_min = 0.01")
            .replace("[coupling]", "[coupling]\neps_min = 0.01")
            .replace(
                "max_relaxation = 1.0",
                "max_relaxation = 1.0\nfrozen = true",
            )
    })
    .unwrap();
    // squeeze every sphere into the first cell column
    for p in c.dem.p.pos.iter_mut() {
        p.x = 2.5e-4;
        p.y = 2.5e-4;
    }
    for _ in 0..20 {
        c.step().unwrap();
    }
    assert!(c.eps.iter().any(|&e| e == 0.01));
    assert!(c.record.u.iter().all(|u| u.iter().all(|v| v.is_finite())));
    assert!(c.lbm.mass().is_finite());
}

/// The seed's lens weights do not add up to the particle volume, but the exchange still
/// balances: the shares are normalised by the solid volume of each cell.
#[test]
fn lens_variant_balances_momentum() {
    let mut c = quick(|t| t.replace("overlap = \"exact\"", "overlap = \"seed-lens\"")).unwrap();
    let b = c.step().unwrap();
    let sum: f64 = c.hydro_n.iter().map(|f| f.z).sum();
    assert!(sum.abs() > 0.0);
    assert!(b.relative_error() < 1e-12, "{}", b.relative_error());
}

/// The ledger closes with the floor in it: particles of the quick scene settle onto the
/// floor and every coupling step balances to rounding, wall impulse included.
#[test]
fn ledger_closes_with_wall_contacts() {
    let mut c = quick(|t| t).unwrap();
    let (mut wall, mut steps_with_wall) = (0.0f64, 0);
    for _ in 0..4000 {
        let b = c.step().unwrap();
        assert!(
            b.relative_error() < 1e-12,
            "step {}: {}",
            c.steps,
            b.relative_error()
        );
        if b.walls.norm() > 0.0 {
            steps_with_wall += 1;
            wall = wall.max(b.walls.norm() / b.scale);
        }
        if steps_with_wall >= 50 {
            break;
        }
    }
    eprintln!("{} steps, {steps_with_wall} with wall contacts, largest wall share {wall:.3}, worst {:.2e}", c.steps, c.worst_balance);
    assert!(
        steps_with_wall >= 50 && wall > 1e-3,
        "the floor was not reached"
    );
}

/// A basesheet adds lattice layers under the floor, keeps the particles' porosity where it
/// was (shifted by its thickness) and its drag enters the ledger; bad values name the key.
#[test]
fn basesheet_layers_and_ledger() {
    let sheet = "[fluid.basesheet]\nthickness_m = 1e-3\npermeability_m2 = 1e-10\n[coupling]";
    let mut plain = quick(|t| t).unwrap();
    let mut c = quick(|t| t.replacen("[coupling]", sheet, 1)).unwrap();
    assert_eq!(c.sheet_cells, 2);
    assert_eq!(c.dims.nz, plain.dims.nz + 2);
    plain.update_porosity().unwrap();
    c.update_porosity().unwrap();
    let nxy = c.dims.nx * c.dims.ny;
    // the same cells shifted (the shifted centre rounds differently: 1e-15)
    for (a, b) in c.eps[2 * nxy..].iter().zip(&plain.eps) {
        assert!((a - b).abs() < 1e-12, "{a} vs {b}");
    }
    assert!(c.eps[..2 * nxy].iter().all(|&e| e == 1.0));
    for _ in 0..30 {
        let b = c.step().unwrap();
        assert!(b.relative_error() < 1e-12, "{}", b.relative_error());
    }
    assert!(c.last_balance.walls.z.abs() > 0.0);
    let e = quick(|t| t.replacen("[coupling]", &sheet.replace("1e-10", "-1.0"), 1))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("fluid.basesheet.permeability_m2"), "{e}");
    let e = quick(|t| t.replacen("[coupling]", &sheet.replace("1e-3", "7e-4"), 1))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("fluid.basesheet.thickness_m"), "{e}");
}

/// A quick-scene run stopped half-way, saved through JSON and restored into a freshly
/// built system ends in bitwise the state of the uninterrupted run, with contacts (and
/// their tangential springs) formed on the way.
#[test]
fn restored_run_continues_bitwise() {
    let scene = parse_scene(include_str!("../builtin/coupled-quick.toml"), "t").unwrap();
    let (k, n) = (100, 200); // the scene's own 200 coupling steps, stopped half-way
    let mut whole = build(&scene).unwrap();
    for _ in 0..n {
        whole.step().unwrap();
    }
    let mut first = build(&scene).unwrap();
    for _ in 0..k {
        first.step().unwrap();
    }
    let text = serde_json::to_string(&first.save_state()).unwrap();
    let mut second = build(&scene).unwrap();
    second
        .load_state(&serde_json::from_str(&text).unwrap())
        .unwrap();
    for _ in k..n {
        second.step().unwrap();
    }
    assert_eq!(whole.save_state(), second.save_state());
    assert_eq!(whole.record.rho, second.record.rho);
    assert!(whole.dem.nl.pairs.iter().any(|p| p.delta > 0.0));
    // a state of another lattice is refused by name
    let mut s = first.save_state();
    s.slip.pop();
    let e = second.load_state(&s).unwrap_err().to_string();
    assert!(e.contains("lattice cells"), "{e}");
}

fn quiet() -> RunOptions {
    RunOptions {
        quiet: true,
        ..Default::default()
    }
}

/// A run stopped after 30 coupling steps and resumed from its checkpoint writes bitwise
/// the outputs of the uninterrupted run (all but the wall-clock figures of the summary);
/// a checkpoint of another scene is refused, naming the file.
#[test]
fn interrupted_run_resumes_to_the_same_result() {
    let base = std::env::temp_dir().join(format!("porelab-coupled-resume-{}", std::process::id()));
    let (whole, killed) = (base.join("whole"), base.join("killed"));
    let text = include_str!("../builtin/coupled-quick.toml")
        .replace("time_s = 0.25", "time_s = 0.1")
        .replace("frames_every_s = 0.125", "frames_every_s = 0.05");
    run_scene(&text, "test", &whole, &quiet()).unwrap();
    run_scene_limited(&text, "test", &killed, &quiet(), Some(30)).unwrap();
    assert!(killed.join("checkpoint.json").exists());
    assert!(!killed.join("summary.json").exists());
    // a second interruption, from the checkpoint, then the rest
    run_scene_limited(&text, "test", &killed, &quiet(), Some(17)).unwrap();
    run_scene(&text, "test", &killed, &quiet()).unwrap();
    assert!(!killed.join("checkpoint.json").exists());
    let read = |d: &Path, f: &str| std::fs::read(d.join(f)).unwrap();
    for f in [
        "porosity_profile.csv",
        "frame_0000.xyz",
        "frame_0001.xyz",
        "frame_0002.xyz",
        "fluid_0001.vtk",
        "fluid_0002.vtk",
    ] {
        assert!(read(&whole, f) == read(&killed, f), "{f} differs");
    }
    let strip = |d: &Path| -> serde_json::Value {
        let mut v: serde_json::Value = serde_json::from_slice(&read(d, "summary.json")).unwrap();
        for k in ["seconds", "timing", "coupling_share", "threads"] {
            v.as_object_mut().unwrap().remove(k);
        }
        v
    };
    let s = strip(&whole);
    assert_eq!(s["coupling_steps"], 80);
    assert_eq!(s, strip(&killed));
    run_scene_limited(&text, "test", &killed, &quiet(), Some(5)).unwrap();
    crate::scene::assert_other_scene_refused(|t| run_scene(t, "test", &killed, &quiet()), &text);
    let _ = std::fs::remove_dir_all(&base);
}

#[test]
fn builtins_parse_and_bad_keys_are_named() {
    for b in builtins() {
        parse_scene(b.toml, b.name).unwrap_or_else(|e| panic!("{}: {e}", b.name));
    }
    let bad = include_str!("../builtin/coupled-quick.toml")
        .replace("[coupling]", "[coupling]\nbogus = 1");
    let e = parse_scene(&bad, "t").err().unwrap().to_string();
    assert!(e.contains("bogus"), "{e}");
    let bad = include_str!("../builtin/coupled-quick.toml")
        .replace("overlap = \"exact\"", "overlap = \"cube\"");
    let e = parse_scene(&bad, "t").err().unwrap().to_string();
    assert!(e.contains("overlap") && e.contains("cube"), "{e}");
    // the DEM's time step is the coupling's, dt_LBM / M: a given one is refused by name
    let bad = include_str!("../builtin/coupled-quick.toml")
        .replace("[fluid]", "[dem.run]\ndt_s = 1e-6\n[fluid]");
    let e = build(&parse_scene(&bad, "t").unwrap())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("dem.run.dt_s"), "{e}");
    // the [dem] table is a DEM scene without its kind
    let bad =
        include_str!("../builtin/coupled-quick.toml").replace("[dem]\n", "[dem]\nkind = \"dem\"\n");
    let e = parse_scene(&bad, "t").err().unwrap().to_string();
    assert!(e.contains("dem.kind"), "{e}");
}

/// Between steps the porosity is that of the particles where they are (the frames show both
/// at one time): recomputing it from the current positions changes nothing. Before the first
/// step the fluid's pressure deviation is 0 everywhere (it once showed -rho c_s^2 from an
/// empty record).
#[test]
fn porosity_and_pressure_belong_to_the_time_they_are_shown_at() {
    let mut c = quick(|t| t).unwrap();
    assert!(c.pressure_si().iter().all(|&p| p == 0.0));
    assert!(c.velocity_si().iter().all(|u| *u == [0.0; 3]));
    for _ in 0..20 {
        c.step().unwrap();
    }
    let moved = c.eps.clone();
    c.update_porosity().unwrap();
    assert_eq!(moved, c.eps);
    assert!(c.eps.iter().any(|&e| e < 1.0));
}
