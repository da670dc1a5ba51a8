//! The run of a packing scene: a fresh start or a resume from `checkpoint.json`, then the
//! engine's driver ([`packing::driver::run`]) with this scene's hooks: a progress line, the
//! checkpoint written atomically as it goes (bitwise resumable), and, in tests, a stop after a
//! set number of steps.

use super::outputs::{describe_particles, read_checkpoint, write_checkpoint, write_outputs};
use super::schema::{parse_scene, PackingScene};
use crate::driver::Hooks;
use crate::packing::{self, driver::Ended, Container, Mcm, Scheme, StepOutcome};
use crate::scene::{on_threads, RunOptions};
use crate::Result;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `porelab run` entry point for `kind = "packing"`.
/// `--threads` sets the worker threads of the parallel analysis (the MCM moves themselves are
/// sequential); results do not depend on it.
pub fn run_scene(text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    on_threads(opts.threads, || {
        run_scene_limited(text, origin, out, opts, None)
    })
}

/// Runs (or resumes) a scene; with `max_new_steps` it stops after that many compression
/// steps, leaving the checkpoint behind as an interrupted run would (used by the tests).
pub(super) fn run_scene_limited(
    text: &str,
    origin: &str,
    out: &Path,
    opts: &RunOptions,
    max_new_steps: Option<usize>,
) -> Result<()> {
    // The result on stdout (even with --quiet, which hides progress), the report on stderr.
    if let Some(summary) = run_to_outputs(text, origin, out, opts, max_new_steps)? {
        println!("{summary}");
        if !opts.quiet {
            eprintln!("outputs in {}", out.display());
        }
    }
    Ok(())
}

/// Runs (or resumes) a packing scene into `out` as [`run_scene`] does, for a scene that
/// builds on it (a filter's bed), without the summary on stdout: the path of its
/// `final.xyz`, or None when the run was stopped (its checkpoint written). A finished run
/// resumes from its final checkpoint and writes the same outputs again.
pub(crate) fn run_for_configuration(
    text: &str,
    origin: &str,
    out: &Path,
    opts: &RunOptions,
) -> Result<Option<PathBuf>> {
    Ok(run_to_outputs(text, origin, out, opts, None)?.map(|_| out.join("final.xyz")))
}

/// The run and its files; the summary, or None when stopped.
fn run_to_outputs(
    text: &str,
    origin: &str,
    out: &Path,
    opts: &RunOptions,
    max_new_steps: Option<usize>,
) -> Result<Option<String>> {
    opts.check_checkpoint_interval()?;
    let scene = parse_scene(text, origin)?;
    let setup = &scene.setup;
    // Upper estimate: a 40000-sphere run holds about 30 MB (750 bytes a particle: state,
    // neighbour lists, the relaxation's arrays); 2 kB a particle leaves room for rods' longer
    // lists and the analysis.
    crate::scene::check_memory(
        origin,
        &format!("particles n = {} (about 2 kB per particle)", setup.n),
        2048.0 * setup.n as f64,
    )?;
    let ckpt_path = out.join("checkpoint.json");
    let (mut mcm, seconds) = if ckpt_path.exists() {
        let (state, seconds) = read_checkpoint(&ckpt_path, &scene)?;
        if !opts.quiet {
            eprintln!(
                "resuming {} from {} (step {}, phi = {:.4})",
                origin,
                ckpt_path.display(),
                state.history.len(),
                state.packing.packing_fraction()
            );
        }
        (Mcm::resume(setup.clone(), state)?, seconds)
    } else {
        (Mcm::new(setup.clone())?, 0.0)
    };
    // Only now, with the scene and its start checked: a refused scene leaves no empty folder.
    crate::io::create_dir(out)?;
    if !opts.quiet {
        eprintln!(
            "packing: {} particles ({}), {:?} scheme (eq. {}), {}, seed {}; stages: {}",
            setup.n,
            describe_particles(&setup.particles()),
            setup.scheme,
            match setup.scheme {
                Scheme::Original => "2.4-2.10",
                Scheme::Revised => "3.2-3.13",
                Scheme::Relax => "FIRE descent of the overlap energy, packing::relax",
            },
            match setup.container {
                Container::Periodic => "periodic cubic box".to_string(),
                Container::Cylinder { diameter } => format!(
                    "cylinder D_cyl = {diameter} (virtual-particle wall, sec. 2.2.4), periodic along z"
                ),
                Container::Wedge { length, angle_rad } => format!(
                    "wedge l_w = {length}, alpha = {} deg (virtual-particle walls, sec. 2.2.4), periodic along z",
                    angle_rad.to_degrees()
                ),
            },
            setup.seed,
            setup.stages()
        );
    }
    let mut hooks = SceneHooks::new(&scene, ckpt_path, opts, seconds, max_new_steps, &mcm);
    let ended = packing::driver::run(&mut mcm, &mut hooks)?;
    hooks.bar.finish_and_clear();
    if ended == Ended::Stopped {
        return Ok(None);
    }
    let (summary, rattler_free_mean_defined) =
        write_outputs(out, origin, &scene, mcm.state(), hooks.seconds)?;
    if !rattler_free_mean_defined {
        eprintln!(
            "warning: with analysis.rattler_min_contacts = {} every particle is a rattler at some \
             cut-off, so contacts_extrapolated_no_rattlers is null; set a lower threshold",
            scene.analysis.rattler_min_contacts
        );
    }
    Ok(Some(summary))
}

/// The scene's side of a run: the progress line, the throttled checkpoint and the stop after
/// `max_new_steps` steps.
struct SceneHooks<'a> {
    scene: &'a PackingScene,
    path: PathBuf,
    /// Seconds between checkpoints (None: after every step).
    every: Option<f64>,
    bar: indicatif::ProgressBar,
    /// Wall time of the run so far, with the time of the runs it resumes.
    seconds: f64,
    base: f64,
    t0: Instant,
    last_checkpoint: Instant,
    max_new_steps: Option<usize>,
    new_steps: usize,
    stopping: bool,
    /// The stage shown, when it began and the moves it had then (for its ETA).
    stage: (u32, Instant, u64),
}

impl<'a> SceneHooks<'a> {
    fn new(
        scene: &'a PackingScene,
        path: PathBuf,
        opts: &RunOptions,
        seconds: f64,
        max_new_steps: Option<usize>,
        mcm: &Mcm,
    ) -> SceneHooks<'a> {
        let bar = if opts.quiet {
            indicatif::ProgressBar::hidden()
        } else {
            let b = indicatif::ProgressBar::new_spinner();
            b.set_style(
                indicatif::ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
            );
            b
        };
        let now = Instant::now();
        SceneHooks {
            scene,
            path,
            every: opts.checkpoint_every_seconds,
            bar,
            seconds,
            base: seconds,
            t0: now,
            last_checkpoint: now,
            max_new_steps,
            new_steps: 0,
            stopping: false,
            stage: (mcm.state().stage, now, mcm.state().stage_tries),
        }
    }
}

impl Hooks<Mcm> for SceneHooks<'_> {
    /// The stop of the tests, after `max_new_steps` steps.
    fn stop_requested(&mut self, _: &Mcm) -> bool {
        self.stopping |= self.max_new_steps.is_some_and(|m| self.new_steps >= m)
            || crate::driver::stop_signalled();
        self.stopping
    }

    /// After every step, and at a stop: the checkpoint is written when the interval has passed,
    /// after a halving, at the end, and at a stop (the state reached between throttled
    /// checkpoints).
    fn checkpoint(&mut self, mcm: &Mcm) -> Result<()> {
        if !self.stopping {
            self.new_steps += 1;
            self.seconds = self.base + self.t0.elapsed().as_secs_f64();
        }
        let due = self
            .every
            .is_none_or(|t| self.last_checkpoint.elapsed().as_secs_f64() >= t);
        if self.stopping || due || mcm.last_outcome() != Some(StepOutcome::Accepted) {
            write_checkpoint(&self.path, self.scene, mcm.state(), self.seconds)?;
            self.last_checkpoint = Instant::now();
        }
        Ok(())
    }

    /// The driver's status line, with the share of the stage's budget of moves used and, from
    /// the rate so far, the most time the stage can still take (it may end sooner, on its
    /// halvings).
    fn progress(&mut self, mcm: &Mcm, _: Option<f64>, status: &str) {
        let state = mcm.state();
        if state.stage != self.stage.0 {
            self.stage = (state.stage, Instant::now(), state.stage_tries);
        }
        let (_, stage_t0, stage_tries0) = self.stage;
        let budget = mcm
            .setup()
            .stage_params(state.stage)
            .stage_budget_per_particle
            .map_or(String::new(), |b| {
                let n = state.packing.n() as f64;
                let used = state.stage_tries as f64 / n;
                let done_here = (state.stage_tries - stage_tries0) as f64 / n;
                let eta = (done_here > 0.0)
                    .then(|| stage_t0.elapsed().as_secs_f64() * (b - used).max(0.0) / done_here);
                format!(
                    "  stage moves/N {used:.0} of {b:.0}{}",
                    eta.map_or(String::new(), |t| format!(" (stage ends within {t:.0} s)"))
                )
            });
        self.bar.set_message(format!("{status}{budget}"));
        self.bar.tick();
    }
}
