//! The run of a deposition scene: its independent runs in parallel, each through the engine's
//! driver ([`deposition::driver::run`]) from its own random stream, then measured; results
//! in run order, the same at any thread count. Each run saves its state in `checkpoint.json`
//! ([`super::checkpoint`]); an interrupted scene run again into the same folder resumes every
//! run from its saved state to bitwise the outputs of an uninterrupted run.

use super::checkpoint::{Checkpoints, RunCheckpoint};
use super::outputs::{ensemble, fmt_mean, write_outputs, RunResult};
use super::schema::{parse_scene, DepositionScene};
use crate::deposition::driver::Deposited;
use crate::deposition::measure::measure;
use crate::deposition::{self, Deposition};
use crate::driver::Hooks;
use crate::error::Error;
use crate::scene::{on_threads, RunOptions};
use crate::Result;
use rayon::prelude::*;
use std::path::Path;
use std::time::Instant;

/// `porelab run` entry point for `kind = "deposition"`.
pub fn run_scene(text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    run_scene_limited(text, origin, out, opts, None)
}

/// Runs (or resumes from `out/checkpoint.json`) a scene; with `max_sweeps` every run stops
/// after that many sweeps, leaving the checkpoint behind as an interrupted run would (tests).
pub(super) fn run_scene_limited(
    text: &str,
    origin: &str,
    out: &Path,
    opts: &RunOptions,
    max_sweeps: Option<u64>,
) -> Result<()> {
    opts.check_checkpoint_interval()?;
    let scene = parse_scene(text, origin)?;
    let store = Checkpoints::open(out, text, scene.runs)?;
    let limits = Limits {
        checkpoint_every_s: opts.checkpoint_every_seconds,
        max_sweeps,
    };
    on_threads(opts.threads, || {
        run_parsed(&scene, origin, out, opts, &store, limits)
    })
}

/// Run `k` of `scene` to its end with `hooks`, and its measures.
pub fn run_one(
    scene: &DepositionScene,
    k: usize,
    hooks: &mut impl Hooks<Deposition>,
) -> Result<RunResult> {
    let t0 = Instant::now();
    let deposit = deposition::driver::run_one(&scene.setup, k, hooks)?;
    measured(scene, deposit, t0)
}

/// The run with its measures; `t0` when it started (its wall time, resumed parts excluded).
fn measured(scene: &DepositionScene, deposit: Deposited, t0: Instant) -> Result<RunResult> {
    let measures = measure(&deposit.layer, scene.setup.species.len(), &scene.measure)?;
    Ok(RunResult {
        deposit,
        measures,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// When the runs save their state, and when a test stops them.
#[derive(Clone, Copy)]
struct Limits {
    checkpoint_every_s: Option<f64>,
    max_sweeps: Option<u64>,
}

/// What run `k` of a scene does after each sweep: saves its state when due, shows run 0's
/// sweep on the progress bar every 50 sweeps, and stops on a signal (the driver's stop flag)
/// or, in tests, after `max_sweeps` sweeps.
struct RunHooks<'a> {
    k: usize,
    store: &'a Checkpoints,
    bar: &'a indicatif::ProgressBar,
    limits: Limits,
    start_seconds: f64,
    /// Wall time of the parts before an interruption, s.
    base_seconds: f64,
    started: Instant,
    last_checkpoint: Instant,
}

impl RunHooks<'_> {
    fn save(&mut self, d: &Deposition) -> Result<()> {
        self.last_checkpoint = Instant::now();
        self.store.save(
            self.k,
            RunCheckpoint {
                start_seconds: self.start_seconds.to_bits(),
                seconds: (self.base_seconds + self.started.elapsed().as_secs_f64()).to_bits(),
                state: d.save_state(),
            },
        )
    }
}

impl Hooks<Deposition> for RunHooks<'_> {
    fn progress(&mut self, d: &Deposition, _: Option<f64>, status: &str) {
        if self.k == 0 && d.outcome().sweeps.is_multiple_of(50) {
            self.bar.set_message(format!("(run 0: {status})"));
        }
    }

    fn checkpoint(&mut self, d: &Deposition) -> Result<()> {
        let due = self
            .limits
            .checkpoint_every_s
            .is_none_or(|t| self.last_checkpoint.elapsed().as_secs_f64() >= t);
        // a finished run is saved once, by run_resumable
        if due && !d.is_done() {
            self.save(d)?;
        }
        Ok(())
    }

    fn stop_requested(&mut self, d: &Deposition) -> bool {
        self.limits
            .max_sweeps
            .is_some_and(|m| d.outcome().sweeps >= m)
            || crate::driver::stop_signalled()
    }
}

/// Run `k`, from its saved state in `store` if there is one, to its end (Some, measured, its
/// final state saved) or to a stop (None, its state saved).
fn run_resumable(
    scene: &DepositionScene,
    k: usize,
    store: &Checkpoints,
    bar: &indicatif::ProgressBar,
    limits: Limits,
) -> Result<Option<RunResult>> {
    let t0 = Instant::now();
    let f = f64::from_bits;
    let (mut d, start_seconds, base_seconds) = match store.saved(k) {
        Some(c) => (
            Deposition::restore(&scene.setup, k, &c.state).map_err(|e| Error::File {
                path: store.path().display().to_string(),
                msg: format!("run {k}: {e}"),
            })?,
            f(c.start_seconds),
            f(c.seconds),
        ),
        None => {
            let d = Deposition::new(&scene.setup, k)?;
            (d, t0.elapsed().as_secs_f64(), 0.0)
        }
    };
    let mut hooks = RunHooks {
        k,
        store,
        bar,
        limits,
        start_seconds,
        base_seconds,
        started: t0,
        last_checkpoint: Instant::now(),
    };
    deposition::driver::run(&mut d, &mut hooks)?;
    // finished or stopped, the state is saved: a later process resumes (or skips) this run
    hooks.save(&d)?;
    if !d.is_done() {
        return Ok(None);
    }
    let (layer, outcome) = d.into_parts();
    let deposit = Deposited {
        run: k,
        layer,
        outcome,
        start_seconds,
    };
    let mut r = measured(scene, deposit, t0)?;
    r.seconds += base_seconds;
    Ok(Some(r))
}

fn run_parsed(
    scene: &DepositionScene,
    origin: &str,
    out: &Path,
    opts: &RunOptions,
    store: &Checkpoints,
    limits: Limits,
) -> Result<()> {
    let setup = &scene.setup;
    if !opts.quiet {
        let counts = setup.counts();
        let sp: Vec<String> = setup
            .species
            .iter()
            .zip(&counts)
            .map(|(s, n)| format!("{n} x {} {:?} m", s.name, s.semi_axes_m))
            .collect();
        eprintln!(
            "deposition: {}; box {:.4e} m, {} % solids -> pigment fraction {:.4}, fluid {:.1} \
             kg/m^3; K_max {:e} m^2; {} runs, seed {}",
            sp.join(" + "),
            setup.box_side_m,
            setup.colour.solids_mass_fraction * 100.0,
            scene.phi,
            setup.fluid_density_kg_m3,
            setup.moves.k_max_m2,
            scene.runs,
            setup.seed
        );
        eprintln!("active terms: {}", setup.active_terms().join(", "));
        if store.resumed() > 0 {
            eprintln!(
                "resuming {} of {} runs from {}",
                store.resumed(),
                scene.runs,
                store.path().display()
            );
        }
    }
    let bar = if opts.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        let b = indicatif::ProgressBar::new(scene.runs as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template("[{elapsed_precise}] runs {pos}/{len} {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    };
    let t0 = Instant::now();
    let results: Vec<Result<Option<RunResult>>> = (0..scene.runs)
        .into_par_iter()
        .map(|k| {
            let r = run_resumable(scene, k, store, &bar, limits);
            bar.inc(1);
            r
        })
        .collect();
    bar.finish_and_clear();
    let results: Vec<Option<RunResult>> = results.into_iter().collect::<Result<_>>()?;
    let Some(results) = results.into_iter().collect::<Option<Vec<RunResult>>>() else {
        // stopped: the checkpoint holds every run's state
        return Ok(());
    };
    write_outputs(scene, origin, out, &results, t0.elapsed().as_secs_f64())?;
    // the outputs are complete: the checkpoint is no longer needed
    store.remove()?;
    let ens = ensemble(&results);
    let core = ens.iter().find(|r| r.0 == "core_porosity");
    // spheres only: the fraction at rest on their contacts (support.rs)
    let supported = ens
        .iter()
        .find(|r| r.0 == "supported_fraction" && r.3 > 0)
        .map(|r| format!("; supported fraction {}", fmt_mean(Some(r))))
        .unwrap_or_default();
    println!(
        "deposition: {} runs in {:.1} s; layer porosity {}; core porosity {}{supported}; \
         outputs in {}",
        results.len(),
        t0.elapsed().as_secs_f64(),
        fmt_mean(ens.iter().find(|r| r.0 == "layer_porosity")),
        fmt_mean(core),
        out.display()
    );
    Ok(())
}
