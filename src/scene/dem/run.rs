//! `porelab run` on a DEM scene: builds the engine from the scene's setup, runs it to rest with
//! the engine's driver ([`crate::dem::run_to_rest`]), whose hooks here write the history,
//! trajectory frames, checkpoints and the progress bar, and writes the outputs. An interrupted
//! run resumes from `checkpoint.json` bitwise.

use super::outputs::{
    history_resumed, history_row, history_table, print_summary, write_frame, write_results,
};
use super::schema::{parse_scene, DemScene};
use crate::dem::checkpoint::DemState;
use crate::dem::{run_to_rest, Check, Dem, Progress};
use crate::driver::Hooks;
use crate::error::Error;
use crate::io::{write_atomic, CsvTable};
use crate::scene::{on_threads, read_checkpoint_file, RunOptions};
use crate::Result;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Builds the engine of a parsed scene (its start: the scene's random dispersion).
pub fn build(scene: &DemScene) -> Result<Dem> {
    Dem::new(scene.setup.clone())
}

/// The checkpoint file: the scene's fingerprint, the run's progress and history so far, and
/// the engine state (floats as IEEE-754 bits).
#[derive(serde::Serialize, serde::Deserialize)]
struct Checkpoint {
    format: u32,
    scene: String,
    seconds: u64,
    ke_peak_j: u64,
    top_prev_m: u64,
    checks: u64,
    balanced_checks: u64,
    imbalance: u64,
    floor_force_mean_n: u64,
    history: String,
    state: DemState,
}

/// Format 3: the stop rule's force balance (format 2: the neighbour-list pairs keep no forces,
/// those are recomputed every step).
const CHECKPOINT_FORMAT: u32 = 3;

fn write_checkpoint(
    path: &Path,
    scene: &DemScene,
    dem: &Dem,
    progress: &Progress,
    history: &CsvTable,
    seconds: f64,
) -> Result<()> {
    let c = Checkpoint {
        format: CHECKPOINT_FORMAT,
        scene: scene.fingerprint.clone(),
        seconds: seconds.to_bits(),
        ke_peak_j: progress.ke_peak_j.to_bits(),
        top_prev_m: progress.top_prev_m.to_bits(),
        checks: progress.checks,
        balanced_checks: progress.balanced_checks,
        imbalance: progress.imbalance.to_bits(),
        floor_force_mean_n: progress.floor_force_mean_n.to_bits(),
        history: history.as_str().to_string(),
        state: dem.save_state(),
    };
    let bytes = serde_json::to_vec(&c).map_err(|e| Error::InvalidInput(e.to_string()))?;
    write_atomic(path, &bytes)
}

/// The scene a checkpoint was written by.
fn scene_of(c: &Checkpoint) -> &str {
    &c.scene
}

/// Restores `dem` from the checkpoint at `path`, if there is one: (progress, history so far,
/// seconds so far).
fn read_checkpoint(
    path: &Path,
    scene: &DemScene,
    dem: &mut Dem,
) -> Result<Option<(Progress, CsvTable, f64)>> {
    let fingerprint = &scene.fingerprint;
    let Some(c) = read_checkpoint_file(path, CHECKPOINT_FORMAT, "DEM", fingerprint, scene_of)?
    else {
        return Ok(None);
    };
    let file_err = |msg: String| Error::File {
        path: path.display().to_string(),
        msg,
    };
    dem.load_state(&c.state)
        .map_err(|e| file_err(e.to_string()))?;
    let f = f64::from_bits;
    Ok(Some((
        Progress {
            ke_peak_j: f(c.ke_peak_j),
            top_prev_m: f(c.top_prev_m),
            checks: c.checks,
            balanced_checks: c.balanced_checks,
            imbalance: f(c.imbalance),
            floor_force_mean_n: f(c.floor_force_mean_n),
        },
        history_resumed(&c.history),
        f(c.seconds),
    )))
}

/// What a scene run does at each check of the driver: a history row, a trajectory frame when
/// due, a checkpoint when due, the progress bar; and the stop after `max_checks` checks that
/// tests use to interrupt a run.
struct SceneHooks<'a> {
    scene: &'a DemScene,
    out: &'a Path,
    checkpoint_path: PathBuf,
    checkpoint_every_s: Option<f64>,
    history: CsvTable,
    bar: indicatif::ProgressBar,
    started: Instant,
    last_checkpoint: Instant,
    base_seconds: f64,
    max_checks: Option<u64>,
    checks_here: u64,
}

impl SceneHooks<'_> {
    /// Wall-clock seconds of the run, the parts before an interruption included.
    fn seconds(&self) -> f64 {
        self.base_seconds + self.started.elapsed().as_secs_f64()
    }
}

impl<'a> Hooks<Check<'a>> for SceneHooks<'_> {
    fn progress(&mut self, _: &Check<'a>, done: Option<f64>, status: &str) {
        self.bar.set_position((done.unwrap_or(0.0) * 1000.0) as u64);
        self.bar.set_message(status.to_string());
    }

    fn checkpoint(&mut self, c: &Check<'a>) -> Result<()> {
        self.checks_here += 1;
        history_row(&mut self.history, self.scene, c);
        let checks = c.progress.checks;
        if let Some(k) = self.scene.outputs.frame_every_checks {
            if checks.is_multiple_of(k) {
                write_frame(self.out, self.scene, c.dem, checks / k)?;
            }
        }
        let due = self
            .checkpoint_every_s
            .is_none_or(|t| self.last_checkpoint.elapsed().as_secs_f64() >= t);
        if due {
            let seconds = self.seconds();
            write_checkpoint(
                &self.checkpoint_path,
                self.scene,
                c.dem,
                c.progress,
                &self.history,
                seconds,
            )?;
            self.last_checkpoint = Instant::now();
        }
        Ok(())
    }

    fn stop_requested(&mut self, _: &Check<'a>) -> bool {
        self.max_checks.is_some_and(|m| self.checks_here >= m) || crate::driver::stop_signalled()
    }
}

/// The progress bar of a run, its position in thousandths of the time limit (hidden when
/// `quiet`).
fn progress_bar(quiet: bool) -> indicatif::ProgressBar {
    if quiet {
        return indicatif::ProgressBar::hidden();
    }
    let b = indicatif::ProgressBar::new(1000);
    b.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} [{elapsed_precise}] {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    b
}

/// `porelab run` on a DEM scene.
pub fn run_scene(text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    run_scene_limited(text, origin, out, opts, None)
}

/// Runs (or resumes from `out/checkpoint.json`) a scene; with `max_checks` it stops after
/// that many checks, leaving the checkpoint behind as an interrupted run would (for tests).
pub(super) fn run_scene_limited(
    text: &str,
    origin: &str,
    out: &Path,
    opts: &RunOptions,
    max_checks: Option<u64>,
) -> Result<()> {
    opts.check_checkpoint_interval()?;
    let scene = parse_scene(text, origin)?;
    let mut dem = build(&scene)?;
    let checkpoint_path = out.join("checkpoint.json");
    let resumed = read_checkpoint(&checkpoint_path, &scene, &mut dem)?;
    let (mut progress, history, base_seconds) = if let Some(resumed) = resumed {
        if !opts.quiet {
            eprintln!(
                "resuming {origin} from {} (step {}, t = {:e} s)",
                checkpoint_path.display(),
                dem.steps,
                dem.time_s
            );
        }
        resumed
    } else {
        (Progress::start(&dem), history_table(), 0.0)
    };
    crate::io::create_dir(out)?;
    eprintln!(
        "dem: {} spheres, dt = {:e} s, skin = {:e} m, active terms: {}",
        dem.p.len(),
        dem.dt_s(),
        dem.nl.skin,
        dem.active().names().join(", ")
    );
    if let (Some(_), 0) = (scene.outputs.frame_every_checks, progress.checks) {
        write_frame(out, &scene, &dem, 0)?;
    }
    let mut hooks = SceneHooks {
        scene: &scene,
        out,
        checkpoint_path,
        checkpoint_every_s: opts.checkpoint_every_seconds,
        history,
        bar: progress_bar(opts.quiet),
        started: Instant::now(),
        last_checkpoint: Instant::now(),
        base_seconds,
        max_checks,
        checks_here: 0,
    };
    let stop = on_threads(opts.threads, || {
        run_to_rest(&mut dem, &scene.rule, &mut progress, &mut hooks)
    })?;
    hooks.bar.finish_and_clear();
    let seconds = hooks.seconds();
    let Some(stop) = stop else {
        // interrupted: the checkpoint holds the state reached
        return write_checkpoint(
            &hooks.checkpoint_path,
            &scene,
            &dem,
            &progress,
            &hooks.history,
            seconds,
        );
    };
    let summary = write_results(
        out,
        &scene,
        &dem,
        &progress,
        &hooks.history,
        stop.reason(&scene.rule),
        seconds,
    )?;
    // the outputs are complete: the checkpoint is no longer needed
    if hooks.checkpoint_path.exists() {
        std::fs::remove_file(&hooks.checkpoint_path).map_err(|e| Error::File {
            path: hooks.checkpoint_path.display().to_string(),
            msg: format!("cannot remove the finished run's checkpoint: {e}"),
        })?;
    }
    print_summary(origin, &summary, out);
    Ok(())
}
