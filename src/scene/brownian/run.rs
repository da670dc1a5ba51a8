//! The run of a Brownian scene: every point of its sweep checked first, then the independent
//! runs of each point in parallel (each the engine's capture experiment, stepped by its
//! driver), kept on disk as they finish so that a killed ensemble resumes.

use super::outputs::{write_summary, CaptureTables, CascadeTable, VolumeTables};
use super::schema::{prepare, CascadeKind, Combo, ExperimentKind, Scene};
use crate::brownian::driver::run_ensemble;
use crate::brownian::experiment::{
    axis_at_angle, capture_volume, run_cascade, CaptureExperiment, CascadeMode, RunResult,
};
use crate::brownian::Simulation;
use crate::driver::Hooks;
use crate::scene::run_store::RunStore;
use crate::scene::RunOptions;
use crate::Result;
use indicatif::{ProgressBar, ProgressStyle};
use nalgebra::Vector3;
use std::path::Path;
use std::time::Instant;

/// A progress bar of `total` steps (hidden when `quiet`).
fn progress(total: u64, quiet: bool, what: &str) -> ProgressBar {
    let pb = if quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(total)
    };
    if let Ok(style) = ProgressStyle::with_template(
        "{msg} [{elapsed_precise}] {wide_bar} {pos}/{len} steps (eta {eta})",
    ) {
        pb.set_style(style);
    }
    pb.set_message(what.to_string());
    // Redrawn every 200 ms from the start, so a run whose first steps are slow (placing and
    // stepping 1e5 particles) shows its bar and elapsed time within the first second.
    if !quiet {
        pb.enable_steady_tick(std::time::Duration::from_millis(200));
    }
    pb
}

/// Moves the shared progress bar by one step after every step of a run.
struct Tick<'a>(&'a ProgressBar);

impl Hooks<Simulation> for Tick<'_> {
    fn progress(&mut self, _: &Simulation, _: Option<f64>, _: &str) {
        self.0.inc(1);
    }
}

/// Checks a Brownian scene as [`run_scene`] does before it runs (`porelab sweep plan`).
pub fn check_scene(text: &str, origin: &str) -> Result<()> {
    prepare(text, origin).map(|_| ())
}

/// Runs a Brownian scene and writes its outputs to `out`.
pub fn run_scene(text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    let started = Instant::now();
    // Build (and so validate) every sweep point before running anything.
    let (scene, combos, exps) = prepare(text, origin)?;
    let first = &exps[0];
    let terms = if scene.experiment == ExperimentKind::CaptureVolume {
        vec!["force on a moment aligned with the local field (eq. 6.20); no dynamics".to_string()]
    } else {
        first
            .setup(
                first.magnet(axis_at_angle(first.alpha))?,
                vec![Vector3::new(1.0, 1.0, 1.0)],
            )?
            .active_terms()
    };
    let threads = opts.threads.unwrap_or_else(rayon::current_num_threads);
    crate::scene::check_memory(
        origin,
        &format!(
            "{} particles per run, mobility \"{}\", {} runs in parallel",
            scene.particle_count(),
            first.hydrodynamics.scene_name(),
            threads.min(scene.run.runs as usize)
        ),
        scene.memory_estimate_bytes(threads),
    )?;
    // Only now, with every sweep point built: a refused scene leaves no empty folder behind.
    crate::io::create_dir(out)?;
    if !opts.quiet {
        eprintln!("porelab run {origin}: {}", scene.title);
        eprintln!("  experiment: {}", serde_json::json!(scene.experiment));
        eprintln!("  active terms: {}", terms.join("; "));
    }
    // Finished runs are kept under out/runs/: a killed ensemble resumes where it stopped.
    let store = RunStore::new(out, text);
    store.check_folder()?;
    // a killed ensemble's half-written files go
    for dir in [out, &out.join("runs")] {
        crate::io::remove_stale_temporaries(dir)?;
    }
    let results = match scene.experiment {
        ExperimentKind::Capture => run_capture(&scene, &combos, &exps, out, opts, &store)?,
        ExperimentKind::Cascade => run_cascades(&scene, &exps, out, opts, &store)?,
        ExperimentKind::CaptureVolume => run_volumes(&scene, &combos, &exps, out)?,
    };
    write_summary(out, origin, &scene, opts, &terms, results, started)?;
    if !opts.quiet {
        eprintln!(
            "  wrote {} ({:.1} s)",
            out.display(),
            started.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

fn run_capture(
    scene: &Scene,
    combos: &[Combo],
    exps: &[CaptureExperiment],
    out: &Path,
    opts: &RunOptions,
    store: &RunStore,
) -> Result<serde_json::Value> {
    let runs = scene.run.runs;
    let total: u64 = exps.iter().map(|e| e.steps() * runs).sum();
    let pb = progress(total, opts.quiet, "capture");
    let mut tables = CaptureTables::new();
    let mut finals = Vec::new();
    for (point, (c, exp)) in combos.iter().zip(exps).enumerate() {
        let results: Vec<RunResult> = run_ensemble(runs, opts.threads, |run| {
            let (r, loaded) = store.load_or_run(&format!("point{point:03}-run{run:04}"), || {
                exp.run(scene.run.seed, run, &mut Tick(&pb))
            })?;
            if loaded {
                pb.inc(exp.steps());
            }
            Ok(r)
        })?;
        finals.push(tables.add_point(c, exp, runs, &results)?);
    }
    pb.finish_and_clear();
    tables.write(out)?;
    // The results on stdout (even with --quiet, which hides progress), the report on stderr.
    for f in &finals {
        println!(
            "L/D = {}, R = {} m, alpha = {} deg: {}",
            f["aspect_ratio"], f["radius_m"], f["alpha_deg"], f["final"]
        );
    }
    Ok(serde_json::Value::Array(finals))
}

fn run_cascades(
    scene: &Scene,
    exps: &[CaptureExperiment],
    out: &Path,
    opts: &RunOptions,
    store: &RunStore,
) -> Result<serde_json::Value> {
    let cs = &scene.cascade;
    if exps.len() != 1 {
        return crate::error::invalid(
            "the cascade takes no [sweep] lists (one particle size and aspect ratio)",
        );
    }
    let exp = &exps[0];
    let runs = scene.run.runs;
    let stage_steps = (cs.stage_time_s / exp.dt_s).round() as u64;
    let pb = progress(
        cs.modes.len() as u64 * runs * cs.stages as u64 * stage_steps,
        opts.quiet,
        "cascade",
    );
    let mut table = CascadeTable::new();
    for kind in &cs.modes {
        let mode = match kind {
            CascadeKind::Random => CascadeMode::Random,
            CascadeKind::Optimal => CascadeMode::Optimal,
        };
        let curves = run_ensemble(runs, opts.threads, |run| {
            let tag = format!("cascade-{mode:?}-run{run:04}").to_lowercase();
            let (curve, loaded) = store.load_or_run(&tag, || {
                run_cascade(
                    exp,
                    mode,
                    cs.stages,
                    cs.stage_time_s,
                    scene.run.seed,
                    run,
                    &mut Tick(&pb),
                )
            })?;
            if loaded {
                pb.inc(cs.stages as u64 * stage_steps);
            }
            Ok(curve)
        })?;
        table.add_mode(&format!("{mode:?}").to_lowercase(), runs, &curves);
    }
    pb.finish_and_clear();
    let summary = table.write(out)?;
    println!("time to 90% capture: {summary}");
    Ok(summary)
}

fn run_volumes(
    scene: &Scene,
    combos: &[Combo],
    exps: &[CaptureExperiment],
    out: &Path,
) -> Result<serde_json::Value> {
    let v = &scene.capture_volume;
    let mut tables = VolumeTables::new();
    for (c, exp) in combos.iter().zip(exps) {
        let magnet = exp.magnet(axis_at_angle(exp.alpha))?;
        let cv = capture_volume(
            &magnet,
            &exp.h0,
            exp.moment.saturation(),
            v.force_cutoff_N,
            v.margin_m,
            v.plane_points,
            v.grid,
        )?;
        if cv.reaches_box {
            eprintln!(
                "  warning: L/D = {}, alpha = {} deg: the capture volume reaches the map box; \
                 it is a lower bound (increase capture_volume.margin_m)",
                c.aspect_ratio, c.alpha_deg
            );
        }
        tables.add_point(c, &cv);
    }
    tables.write(out)
}
