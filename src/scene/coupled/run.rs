//! A coupled run: the system built from its scene, stepped by [`crate::coupled::driver`] with
//! its outputs written by the hooks, checkpointed and resumed.

use super::outputs::{frame, porosity_svg, summarize};
use super::CoupledScene;
use crate::coupled::checkpoint::CoupledState;
use crate::coupled::{driver, Coupled};
use crate::driver::Hooks;
use crate::error::Error;
use crate::io::write_atomic;
use crate::scene::{on_threads, parse_checkpoint, RunOptions};
use crate::Result;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// The coupled system of a parsed scene (the DEM's random dispersion in the lattice).
pub fn build(scene: &CoupledScene) -> Result<Coupled> {
    super::check_size(scene)?;
    Coupled::new(scene.setup.clone())
}

/// The checkpoint file: the scene's fingerprint, the outputs written so far (porosity rows,
/// frame count), the initial fluid mass (the summary's drift) and the engine state.
#[derive(serde::Serialize, serde::Deserialize)]
struct Checkpoint {
    format: u32,
    scene: String,
    seconds: u64,
    mass0: u64,
    frames: usize,
    profile: String,
    /// Wall-clock seconds per part so far (the summary's shares; not part of the result).
    timing: crate::coupled::Timing,
    state: CoupledState,
}

/// Format 2: the neighbour-list pairs keep no forces (those are recomputed every step).
const CHECKPOINT_FORMAT: u32 = 2;

/// Restores `c` from the checkpoint at `path`: (seconds so far, initial mass, frames written,
/// porosity rows so far).
fn read_checkpoint(
    path: &Path,
    fingerprint: &str,
    c: &mut Coupled,
) -> Result<(f64, f64, usize, String)> {
    let file_err = |msg: String| Error::File {
        path: path.display().to_string(),
        msg,
    };
    let bytes =
        std::fs::read(path).map_err(|e| file_err(format!("cannot read the checkpoint: {e}")))?;
    let k: Checkpoint = parse_checkpoint(&bytes, CHECKPOINT_FORMAT, "coupled").map_err(file_err)?;
    if k.scene != fingerprint {
        return Err(file_err(
            "written by a different scene (its text differs): delete it to start afresh, or \
             choose another output folder with --out"
                .into(),
        ));
    }
    c.load_state(&k.state)
        .map_err(|e| file_err(e.to_string()))?;
    c.timing = k.timing;
    Ok((
        f64::from_bits(k.seconds),
        f64::from_bits(k.mass0),
        k.frames,
        k.profile,
    ))
}

pub fn run_scene(text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    run_scene_limited(text, origin, out, opts, None)
}

/// Runs (or resumes from `out/checkpoint.json`) a scene; with `max_steps` it stops after that
/// many coupling steps of this call, leaving the checkpoint behind as an interrupted run would
/// (for tests). A checkpoint is written with the porosity rows, at most every
/// `--checkpoint-every` seconds, and removed when the outputs are complete.
pub(crate) fn run_scene_limited(
    text: &str,
    origin: &str,
    out: &Path,
    opts: &RunOptions,
    max_steps: Option<u64>,
) -> Result<()> {
    opts.check_checkpoint_interval()?;
    let scene = super::parse_scene(text, origin)?;
    let mut c = build(&scene)?;
    let fingerprint = format!("{:016x}", crate::io::fnv1a64(text.as_bytes()));
    let ckpt_path = out.join("checkpoint.json");
    let (base_seconds, mass0, frames, profile) = if ckpt_path.exists() {
        let r = read_checkpoint(&ckpt_path, &fingerprint, &mut c)?;
        if !opts.quiet {
            eprintln!(
                "resuming {origin} from {} (coupling step {}, t = {:e} s)",
                ckpt_path.display(),
                c.steps,
                c.time_s
            );
        }
        r
    } else {
        (0.0, c.lbm.mass(), 0, String::from("time_s,z_m,porosity\n"))
    };
    let d = c.dims;
    eprintln!(
        "coupled: {} spheres, lattice {} x {} x {} (dx = {:e} m), dt_LBM = {:e} s, M = {} DEM \
         steps of dt_DEM = {:e} s; fluid {} {}; porosity {}, drag switch {}; DEM terms: {}",
        c.dem.p.len(),
        d.nx,
        d.ny,
        d.nz,
        c.setup.dx_m,
        c.units.dt,
        c.setup.dem_steps,
        c.dt_dem_s,
        c.lbm.lattice().name(),
        c.lbm.collision().name(),
        c.setup.overlap.name(),
        c.setup.switch.name(),
        c.dem.active().names().join(", ")
    );
    crate::io::create_dir(out)?;
    let total = driver::steps_for(&c, scene.time_s);
    let bar = if opts.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        let b = indicatif::ProgressBar::new(total);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} [{elapsed_precise}] {msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b.set_position(c.steps);
        b
    };
    let mut hooks = SceneHooks {
        out,
        ckpt_path: &ckpt_path,
        fingerprint: &fingerprint,
        base_seconds,
        mass0,
        frames,
        profile,
        frame_steps: ((scene.frames_every_s / c.units.dt).round() as u64).max(1),
        profile_steps: ((scene.profile_every_s / c.units.dt).round() as u64).max(1),
        total,
        checkpoint_every_s: opts.checkpoint_every_seconds,
        start: Instant::now(),
        last_checkpoint: Instant::now(),
        stop_after: max_steps.map(|m| c.steps + m),
        bar,
    };
    let stop = on_threads(opts.threads, || -> Result<driver::Stop> {
        if c.steps == 0 {
            frame(&c, out, hooks.frames)?;
            hooks.frames += 1;
        }
        driver::run_to_step(&mut c, total, &mut hooks)
    })?;
    hooks.bar.finish_and_clear();
    if stop == driver::Stop::Requested {
        // the checkpoint holds the state reached
        return hooks.save(&c);
    }
    let SceneHooks {
        base_seconds,
        start,
        profile,
        ..
    } = hooks;
    let seconds = base_seconds + start.elapsed().as_secs_f64();
    write_atomic(&out.join("porosity_profile.csv"), profile.as_bytes())?;
    porosity_svg(&profile, out);
    let summary = summarize(&scene, &c, seconds, mass0, opts.threads);
    let json =
        serde_json::to_string_pretty(&summary).map_err(|e| Error::InvalidInput(e.to_string()))?;
    write_atomic(&out.join("summary.json"), json.as_bytes())?;
    // the outputs are complete: the checkpoint is no longer needed
    if ckpt_path.exists() {
        std::fs::remove_file(&ckpt_path).map_err(|e| Error::File {
            path: ckpt_path.display().to_string(),
            msg: format!("cannot remove the finished run's checkpoint: {e}"),
        })?;
    }
    println!(
        "{origin}: {} coupling steps ({:.3e} s simulated) in {:.1} s; shares LBM {:.1} %, DEM \
         {:.1} %, coupling {:.1} %; momentum imbalance (walls included) {:.1e}, mass drift {:.1e}",
        summary.coupling_steps,
        summary.simulated_time_s,
        seconds,
        100.0 * summary.timing.lbm_s / seconds,
        100.0 * summary.timing.dem_s / seconds,
        100.0 * summary.coupling_share,
        summary.momentum_imbalance,
        summary.fluid_mass_drift
    );
    println!("outputs in {}", out.display());
    Ok(())
}

/// The scene's side of the driver: porosity rows and frames at their steps, a throttled
/// checkpoint, the progress bar, and the tests' stop after a number of steps.
struct SceneHooks<'a> {
    out: &'a Path,
    ckpt_path: &'a Path,
    fingerprint: &'a str,
    /// Wall-clock seconds of earlier parts of an interrupted run.
    base_seconds: f64,
    /// Fluid mass at the start (the summary's drift).
    mass0: f64,
    /// Frames written so far.
    frames: usize,
    /// porosity_profile.csv so far.
    profile: String,
    frame_steps: u64,
    profile_steps: u64,
    total: u64,
    checkpoint_every_s: Option<f64>,
    start: Instant,
    last_checkpoint: Instant,
    /// Stop (as an interrupted run) once this many coupling steps are done.
    stop_after: Option<u64>,
    bar: indicatif::ProgressBar,
}

impl SceneHooks<'_> {
    fn save(&self, c: &Coupled) -> Result<()> {
        let k = Checkpoint {
            format: CHECKPOINT_FORMAT,
            scene: self.fingerprint.to_string(),
            seconds: (self.base_seconds + self.start.elapsed().as_secs_f64()).to_bits(),
            mass0: self.mass0.to_bits(),
            frames: self.frames,
            profile: self.profile.clone(),
            timing: c.timing,
            state: c.save_state(),
        };
        let bytes = serde_json::to_vec(&k).map_err(|e| Error::InvalidInput(e.to_string()))?;
        write_atomic(self.ckpt_path, &bytes)
    }
}

impl Hooks<Coupled> for SceneHooks<'_> {
    fn progress(&mut self, c: &Coupled, _: Option<f64>, status: &str) {
        self.bar.set_position(c.steps);
        self.bar.set_message(status.to_string());
    }

    fn checkpoint(&mut self, c: &Coupled) -> Result<()> {
        if c.steps % self.profile_steps == 0 {
            let dz = c.setup.dx_m;
            let z0 = c.sheet_cells as f64 * dz;
            for (k, e) in c.porosity_profile().iter().enumerate() {
                let z = (k as f64 + 0.5) * dz - z0;
                let _ = writeln!(self.profile, "{},{},{}", c.time_s, z, e);
            }
        }
        if c.steps % self.frame_steps == 0 {
            frame(c, self.out, self.frames)?;
            self.frames += 1;
        }
        if c.steps % self.profile_steps == 0
            && c.steps < self.total
            && self
                .checkpoint_every_s
                .is_none_or(|t| self.last_checkpoint.elapsed().as_secs_f64() >= t)
        {
            self.save(c)?;
            self.last_checkpoint = Instant::now();
        }
        Ok(())
    }

    fn stop_requested(&mut self, c: &Coupled) -> bool {
        self.stop_after.is_some_and(|s| c.steps >= s) || crate::driver::stop_signalled()
    }
}
