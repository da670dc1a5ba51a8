//! The run loop: a fresh start or a resume from `checkpoint.json`, the compression stages, and
//! the checkpoint written atomically as it goes (bitwise resumable).

use super::outputs::{describe_particles, write_outputs};
use super::schema::{parse_scene, PackingScene};
use crate::error::Error;
use crate::io::write_atomic;
use crate::packing::{self, Container, McmState, Packing, Scheme, StepOutcome, StepRecord};
use crate::scene::{on_threads, RunOptions};
use crate::Result;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};
use std::path::Path;
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
    opts.check_checkpoint_interval()?;
    let scene = parse_scene(text, origin)?;
    let prm = &scene.params;
    // Upper estimate: a 40000-sphere run holds about 30 MB (750 bytes a particle: state,
    // neighbour lists, the relaxation's arrays); 2 kB a particle leaves room for rods' longer
    // lists and the analysis.
    crate::scene::check_memory(
        origin,
        &format!("particles n = {} (about 2 kB per particle)", prm.n),
        2048.0 * prm.n as f64,
    )?;
    let ckpt_path = out.join("checkpoint.json");
    let (mut state, mut seconds) = if ckpt_path.exists() {
        let c = read_checkpoint(&ckpt_path, &scene)?;
        if !opts.quiet {
            eprintln!(
                "resuming {} from {} (step {}, phi = {:.4})",
                origin,
                ckpt_path.display(),
                c.0.history.len(),
                c.0.packing.packing_fraction()
            );
        }
        c
    } else {
        let start = packing::random_start_of(prm.container, prm.particles(), prm.phi0, prm.seed)?;
        (McmState::new(start, prm)?, 0.0)
    };
    // Only now, with the scene and its start checked: a refused scene leaves no empty folder.
    crate::io::create_dir(out)?;
    if !opts.quiet {
        eprintln!(
            "packing: {} particles ({}), {:?} scheme (eq. {}), {}, seed {}; stages: {}",
            prm.n,
            describe_particles(&prm.particles()),
            prm.scheme,
            match prm.scheme {
                Scheme::Original => "2.4-2.10",
                Scheme::Revised => "3.2-3.13",
                Scheme::Relax => "FIRE descent of the overlap energy, packing::relax",
            },
            match prm.container {
                Container::Periodic => "periodic cubic box".to_string(),
                Container::Cylinder { diameter } => format!(
                    "cylinder D_cyl = {diameter} (virtual-particle wall, sec. 2.2.4), periodic along z"
                ),
                Container::Wedge { length, angle_rad } => format!(
                    "wedge l_w = {length}, alpha = {} deg (virtual-particle walls, sec. 2.2.4), periodic along z",
                    angle_rad.to_degrees()
                ),
            },
            prm.seed,
            prm.stages()
        );
    }
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
    let t0 = Instant::now();
    let base = seconds;
    let mut new_steps = 0usize;
    let mut last_checkpoint = Instant::now();
    let (mut stage_seen, mut stage_t0, mut stage_tries0) =
        (state.stage, Instant::now(), state.stage_tries);
    while !state.is_done() {
        if max_new_steps.is_some_and(|m| new_steps >= m) {
            bar.finish_and_clear();
            // Stopped between throttled checkpoints: save the state reached.
            return write_checkpoint(&ckpt_path, &scene, &state, seconds);
        }
        let o = state.step(prm)?;
        new_steps += 1;
        seconds = base + t0.elapsed().as_secs_f64();
        let due = opts
            .checkpoint_every_seconds
            .is_none_or(|t| last_checkpoint.elapsed().as_secs_f64() >= t);
        if due || o != StepOutcome::Accepted {
            write_checkpoint(&ckpt_path, &scene, &state, seconds)?;
            last_checkpoint = Instant::now();
        }
        if o != StepOutcome::Finished {
            // With a stage budget: how much of it the running stage has used.
            // and, from the rate so far, the most time the stage can still take (an ETA: the
            // stage may end sooner, on its halvings).
            if state.stage != stage_seen {
                (stage_seen, stage_t0, stage_tries0) =
                    (state.stage, Instant::now(), state.stage_tries);
            }
            let budget = prm
                .stage_params(state.stage)
                .stage_budget_per_particle
                .map_or(String::new(), |b| {
                    let n = state.packing.n() as f64;
                    let used = state.stage_tries as f64 / n;
                    let done_here = (state.stage_tries - stage_tries0) as f64 / n;
                    let eta = (done_here > 0.0).then(|| {
                        stage_t0.elapsed().as_secs_f64() * (b - used).max(0.0) / done_here
                    });
                    format!(
                        "  stage moves/N {used:.0} of {b:.0}{}",
                        eta.map_or(String::new(), |t| format!(" (stage ends within {t:.0} s)"))
                    )
                });
            bar.set_message(format!(
                "stage {} step {}  phi = {:.5}  Delta V = {:.3e}  halvings left {}  tries {}{budget}",
                state.stage + 1,
                state.history.len(),
                state.packing.packing_fraction(),
                state.delta_v,
                state.halvings_left,
                state.total_tries
            ));
            bar.tick();
        }
    }
    bar.finish_and_clear();
    let (summary, rattler_free_mean_defined) = write_outputs(out, origin, &scene, &state, seconds)?;
    if !rattler_free_mean_defined {
        eprintln!(
            "warning: with analysis.rattler_min_contacts = {} every particle is a rattler at some \
             cut-off, so contacts_extrapolated_no_rattlers is null; set a lower threshold",
            scene.rattler_min_contacts
        );
    }
    // The result on stdout (even with --quiet, which hides progress), the report on stderr.
    println!("{summary}");
    if !opts.quiet {
        eprintln!("outputs in {}", out.display());
    }
    Ok(())
}

/// The checkpoint: the scene fingerprint and the full [`McmState`], every f64 stored as its
/// IEEE bits so the resumed run starts from bitwise the same state.
#[derive(Serialize, Deserialize)]
struct Checkpoint {
    format: u32,
    scene: String,
    seconds: f64,
    box_length: u64,
    positions: Vec<[u64; 3]>,
    /// Quaternion (w, i, j, k) bits.
    orientations: Vec<[u64; 4]>,
    delta_v: u64,
    halvings_left: u32,
    stage: u32,
    /// (step, packing fraction bits, Delta V bits, tries) per accepted step.
    history: Vec<(usize, u64, u64, u64)>,
    failed_steps: usize,
    total_tries: u64,
    /// Moves in the running stage (absent in checkpoints written before stage budgets: 0,
    /// which is exact for their scenes, as they had no budget).
    #[serde(default)]
    stage_tries: u64,
    #[serde(default)]
    stage_budget_spent: bool,
    finished: Option<bool>,
}

fn write_checkpoint(path: &Path, scene: &PackingScene, s: &McmState, seconds: f64) -> Result<()> {
    let p = &s.packing;
    let c = Checkpoint {
        format: 2,
        scene: scene.fingerprint.clone(),
        seconds,
        box_length: p.box_length.to_bits(),
        positions: p
            .positions
            .iter()
            .map(|x| [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()])
            .collect(),
        orientations: p
            .orientations
            .iter()
            .map(|q| {
                let q = q.quaternion();
                [q.w.to_bits(), q.i.to_bits(), q.j.to_bits(), q.k.to_bits()]
            })
            .collect(),
        delta_v: s.delta_v.to_bits(),
        halvings_left: s.halvings_left,
        stage: s.stage,
        history: s
            .history
            .iter()
            .map(|h| {
                (
                    h.step,
                    h.packing_fraction.to_bits(),
                    h.delta_v.to_bits(),
                    h.tries,
                )
            })
            .collect(),
        failed_steps: s.failed_steps,
        total_tries: s.total_tries,
        stage_tries: s.stage_tries,
        stage_budget_spent: s.stage_budget_spent,
        finished: s.finished,
    };
    let text = serde_json::to_vec(&c).map_err(|e| Error::InvalidInput(e.to_string()))?;
    write_atomic(path, &text)
}

pub(super) fn read_checkpoint(path: &Path, scene: &PackingScene) -> Result<(McmState, f64)> {
    let file_err = |msg: String| Error::File {
        path: path.display().to_string(),
        msg,
    };
    let text =
        std::fs::read(path).map_err(|e| file_err(format!("cannot read the checkpoint: {e}")))?;
    let c: Checkpoint = serde_json::from_slice(&text)
        .map_err(|e| file_err(format!("not a packing checkpoint: {e}")))?;
    if c.format != 2 {
        return Err(file_err(format!(
            "checkpoint format {}: this porelab reads format 2",
            c.format
        )));
    }
    if c.scene != scene.fingerprint {
        return Err(file_err(
            "written by a different scene (parameters differ): delete it to start afresh, or \
             choose another output folder with --out"
                .into(),
        ));
    }
    let f = f64::from_bits;
    if c.positions.len() != scene.params.n || c.orientations.len() != scene.params.n {
        return Err(file_err(format!(
            "{} positions, {} orientations: the scene has n = {}",
            c.positions.len(),
            c.orientations.len(),
            scene.params.n
        )));
    }
    let packing = Packing {
        container: scene.params.container,
        box_length: f(c.box_length),
        particles: scene.params.particles(),
        positions: c
            .positions
            .iter()
            .map(|b| Vector3::new(f(b[0]), f(b[1]), f(b[2])))
            .collect(),
        orientations: c
            .orientations
            .iter()
            .map(|b| {
                UnitQuaternion::new_unchecked(Quaternion::new(f(b[0]), f(b[1]), f(b[2]), f(b[3])))
            })
            .collect(),
    };
    let state = McmState {
        packing,
        delta_v: f(c.delta_v),
        halvings_left: c.halvings_left,
        history: c
            .history
            .iter()
            .map(|h| StepRecord {
                step: h.0,
                packing_fraction: f(h.1),
                delta_v: f(h.2),
                tries: h.3,
            })
            .collect(),
        failed_steps: c.failed_steps,
        total_tries: c.total_tries,
        stage_tries: c.stage_tries,
        stage_budget_spent: c.stage_budget_spent,
        stage: c.stage,
        finished: c.finished,
    };
    Ok((state, c.seconds))
}
