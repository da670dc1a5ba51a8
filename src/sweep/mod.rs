//! Parameter sweeps and ensembles: plan, run locally, Slurm job arrays, collect.
//!
//! Sweep file (TOML, unknown keys refused by name; defaults in brackets):
//!
//! ```toml
//! title = "..."                  # free text, copied into every job's header
//! scene = "base.toml"            # the base scene, relative to this file, or instead:
//! builtin = "packing-spheres"    # a built-in scene (`porelab run --list`)
//! combine = "grid"               # "grid" (every combination) | "zip" (equal-length lists
//!                                # side by side) [grid]
//! runs_per_point = 3             # runs (seeds) per point [1]
//! base_seed = 1                  # [1]
//! [vary]                         # dotted key path into the scene -> list of values (TOML
//! "particles.n" = [500, 1000]    # types kept); a number indexes an array of tables,
//! "species.0.fraction" = [0.5]   # e.g. the first [[species]] of a deposition scene
//! ```
//!
//! Each job's seed goes to its engine's seed key ([`crate::scene::Scene::seed_key`]: `run.seed` brownian,
//! `mcm.seed` packing, `seed` deposition and DEM, `dem.seed` coupled; LBM has none and takes one run per point):
//! [`plan::job_seed`], a SplitMix64 chain of (base_seed, point, run).
//!
//! A sweep folder `DIR` (written by `porelab sweep plan`):
//!
//! ```text
//! DIR/sweep.toml               copy of the sweep file
//! DIR/manifest.csv             job,point,run,seed,<varied keys>,scene_fnv1a64 (written last)
//! DIR/jobs/NNNNN/scene.toml    the complete scene of job NNNNN (header: point values, seed)
//! DIR/jobs/NNNNN/claim.json    the process running the job ([`claim`]; O_EXCL, liveness-checked)
//! DIR/jobs/NNNNN/work/         a job under way, with its checkpoint (kept until done: resumed)
//! DIR/jobs/NNNNN/out/          its outputs, renamed from work/ once summary.json is written
//! DIR/jobs/NNNNN/done.json     written atomically after the rename: the job is finished
//! DIR/jobs/NNNNN/failed.json   the error of a failed job
//! DIR/jobs/NNNNN/interrupted.json  a job stopped by a signal: "timed out" or "cancelled (...)"
//! DIR/slurm/arrays.csv         the arrays `sweep slurm --submit` submitted: id, first job
//! DIR/collected.csv            `porelab sweep collect`: per point mean, standard error, count
//! ```
//!
//! Every job writes only into its own folder, so local workers and Slurm tasks never write the
//! same file, and the collected table depends only on the jobs' results.

pub mod builtin;
pub mod claim;
pub mod collect;
pub mod plan;
pub mod plots;
pub mod run;
pub mod slurm;
pub mod status;

use crate::error::{invalid, Error, Result};
use crate::io::write_atomic;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// File names inside a sweep folder.
pub const MANIFEST: &str = "manifest.csv";
pub const SWEEP_COPY: &str = "sweep.toml";

pub use crate::io::fnv1a64;

/// The folder of job `job`.
pub fn job_dir(dir: &Path, job: usize) -> PathBuf {
    dir.join("jobs").join(format!("{job:05}"))
}

/// One job of a plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedJob {
    pub job: usize,
    pub point: usize,
    pub run: usize,
    /// The scene's seed (None for engines without one).
    pub seed: Option<u64>,
    /// The varied keys' values at this point, as the manifest prints them.
    pub values: Vec<String>,
    /// FNV-1a 64 of the scene text.
    pub hash: u64,
    /// The scene text (empty when read back from a manifest).
    pub scene: String,
}

/// The jobs of a sweep and the names of its varied keys.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub keys: Vec<String>,
    pub jobs: Vec<PlannedJob>,
}

impl Plan {
    /// The manifest text: one row per job.
    pub fn manifest_csv(&self) -> String {
        let mut w = csv::Writer::from_writer(vec![]);
        let mut head = vec!["job", "point", "run", "seed"];
        head.extend(self.keys.iter().map(String::as_str));
        head.push("scene_fnv1a64");
        w.write_record(&head).expect("in-memory CSV");
        for j in &self.jobs {
            let mut row = vec![
                format!("{:05}", j.job),
                j.point.to_string(),
                j.run.to_string(),
                j.seed.map(|s| s.to_string()).unwrap_or_default(),
            ];
            row.extend(j.values.iter().cloned());
            row.push(format!("{:016x}", j.hash));
            w.write_record(&row).expect("in-memory CSV");
        }
        String::from_utf8(w.into_inner().expect("in-memory CSV")).expect("UTF-8 fields")
    }

    /// Reads the plan of the sweep folder `dir` from its manifest.
    pub fn read(dir: &Path) -> Result<Plan> {
        let path = dir.join(MANIFEST);
        let named = |msg: String| Error::File {
            path: path.display().to_string(),
            msg,
        };
        let text = std::fs::read_to_string(&path).map_err(|e| {
            named(format!(
                "{e} (is {} a sweep folder written by `porelab sweep plan`?)",
                dir.display()
            ))
        })?;
        let mut r = csv::Reader::from_reader(text.as_bytes());
        let head: Vec<String> = r
            .headers()
            .map_err(|e| named(e.to_string()))?
            .iter()
            .map(String::from)
            .collect();
        let n = head.len();
        if n < 5 || head[..4] != ["job", "point", "run", "seed"] || head[n - 1] != "scene_fnv1a64" {
            return Err(named(format!("unexpected header {head:?}")));
        }
        let keys = head[4..n - 1].to_vec();
        let mut jobs = Vec::new();
        for (line, rec) in r.records().enumerate() {
            let rec = rec.map_err(|e| named(e.to_string()))?;
            let bad = |what: &str| named(format!("row {}: bad {what}", line + 2));
            let num = |i: usize, what: &str| rec[i].parse::<usize>().map_err(|_| bad(what));
            let job = num(0, "job")?;
            if job != jobs.len() {
                return Err(bad("job number (rows must be jobs 0, 1, 2, ...)"));
            }
            jobs.push(PlannedJob {
                job,
                point: num(1, "point")?,
                run: num(2, "run")?,
                seed: match &rec[3] {
                    "" => None,
                    s => Some(s.parse().map_err(|_| bad("seed"))?),
                },
                values: (4..n - 1).map(|i| rec[i].to_string()).collect(),
                hash: u64::from_str_radix(&rec[n - 1], 16).map_err(|_| bad("scene_fnv1a64"))?,
                scene: String::new(),
            });
        }
        if jobs.is_empty() {
            return Err(named("no jobs".into()));
        }
        Ok(Plan { keys, jobs })
    }

    /// The job of index `i`, or an error naming the valid range.
    pub fn job(&self, i: usize) -> Result<&PlannedJob> {
        self.jobs.get(i).ok_or_else(|| {
            Error::InvalidInput(format!(
                "job {i}: the sweep has jobs 0..={}",
                self.jobs.len() - 1
            ))
        })
    }

    /// Number of points (the last job's point + 1).
    pub fn points(&self) -> usize {
        self.jobs.last().map_or(0, |j| j.point + 1)
    }
}

/// Where a job stands, read from its folder.
#[derive(Debug, Clone, PartialEq)]
pub enum JobState {
    /// `done.json` present (written only beside a complete `out/` with its `summary.json`).
    Done,
    /// A live claim (`claim.json`): running now, in the process it names.
    Running(String),
    /// `failed.json` present: its message.
    Failed(String),
    /// `interrupted.json` with reason "timed out": stopped at (or warned of) its time limit;
    /// the next attempt resumes from the checkpoint in `work/`.
    TimedOut,
    /// `interrupted.json` with another reason (cancelled, stopped by a signal): its text.
    Cancelled(String),
    /// A `work/` folder (or a dead claim) and no record: its process was killed (SIGKILL, a
    /// node lost); the next attempt resumes from the checkpoint in `work/`.
    Killed,
    Pending,
}

impl JobState {
    /// The state's name as `sweep status` prints it.
    pub fn name(&self) -> &'static str {
        match self {
            JobState::Done => "done",
            JobState::Running(_) => "running",
            JobState::Failed(_) => "failed",
            JobState::TimedOut => "timed out",
            JobState::Cancelled(_) => "cancelled",
            JobState::Killed => "killed",
            JobState::Pending => "pending",
        }
    }
}

/// The `error` (failed.json) or `reason` (interrupted.json) of a job record, or its text.
fn record_field(path: &Path, field: &str) -> Option<String> {
    let text = std::fs::read_to_string(path).ok()?;
    Some(
        serde_json::from_str::<serde_json::Value>(&text)
            .ok()
            .and_then(|v| v[field].as_str().map(String::from))
            .unwrap_or(text),
    )
}

/// The state of job `job` of the sweep in `dir`.
pub fn job_state(dir: &Path, job: usize) -> JobState {
    let d = job_dir(dir, job);
    if d.join("done.json").is_file() {
        return JobState::Done;
    }
    if let Some(o) = claim::live_holder(&d) {
        return JobState::Running(o.describe());
    }
    if let Some(msg) = record_field(&d.join("failed.json"), "error") {
        return JobState::Failed(msg);
    }
    if let Some(reason) = record_field(&d.join(run::INTERRUPTED), "reason") {
        return if reason == run::TIMED_OUT {
            JobState::TimedOut
        } else {
            JobState::Cancelled(reason)
        };
    }
    let started = std::fs::read_dir(&d)
        .into_iter()
        .flatten()
        .flatten()
        .any(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            name == "work" || name == claim::CLAIM || name.starts_with("tmp-")
        });
    if started {
        JobState::Killed
    } else {
        JobState::Pending
    }
}

/// The jobs still to run: not done, not running, and not failed unless `retry_failed`.
pub fn unfinished(dir: &Path, plan: &Plan, retry_failed: bool) -> Vec<usize> {
    plan.jobs
        .iter()
        .map(|j| j.job)
        .filter(|&j| match job_state(dir, j) {
            JobState::Done | JobState::Running(_) => false,
            JobState::Failed(_) => retry_failed,
            JobState::TimedOut | JobState::Cancelled(_) | JobState::Killed | JobState::Pending => {
                true
            }
        })
        .collect()
}

/// `porelab sweep ...`
#[derive(Debug, clap::Args)]
pub struct SweepArgs {
    #[command(subcommand)]
    pub action: SweepAction,
}

#[derive(Debug, clap::Subcommand)]
pub enum SweepAction {
    /// Expand a sweep file into one checked scene per job under DIR (with a manifest).
    Plan {
        /// The sweep file (TOML).
        sweep: PathBuf,
        /// The sweep folder to write.
        #[arg(long)]
        out: PathBuf,
    },
    /// Run the unfinished jobs on this machine, K at a time (child processes).
    Run {
        dir: PathBuf,
        /// Jobs at once.
        #[arg(long, default_value_t = 1)]
        jobs: usize,
        /// Worker threads per job (default: the cores divided by --jobs); results do not
        /// depend on it.
        #[arg(long)]
        threads: Option<usize>,
        /// Run failed jobs again too.
        #[arg(long)]
        retry_failed: bool,
    },
    /// Run exactly one job (what a Slurm array task calls); exit code 0 done (or running in
    /// another live process), 1 failed, 128 + signal when stopped by SIGTERM, SIGINT or SIGUSR1
    /// (checkpoint written; the next attempt resumes).
    Job {
        dir: PathBuf,
        index: usize,
        #[arg(long)]
        threads: Option<usize>,
        /// Under Slurm: a job stopped at its time limit requeues its array task.
        #[arg(long)]
        requeue: bool,
    },
    /// Write DIR/sweep.sbatch for Slurm job arrays of the jobs still to run (split at the
    /// cluster's MaxArraySize); --submit sends them.
    Slurm(slurm::SlurmArgs),
    /// Counts of done, running, failed, timed-out, cancelled, killed and pending jobs, with
    /// the failed jobs' messages; exit code 1 when any failed.
    Status { dir: PathBuf },
    /// Per point mean, standard error and count of every numeric scalar of the jobs'
    /// summary.json: DIR/collected.csv and DIR/plots/*.svg. Refuses a partial set, jobs of
    /// another porelab version or of another scene kind, unless --partial.
    Collect {
        dir: PathBuf,
        /// Write the table of the finished, converged jobs even when others are missing.
        #[arg(long)]
        partial: bool,
    },
    /// A built-in sweep that redraws a seed figure: plan, run and collect in one command
    /// (again to resume); --list names them.
    Figure(builtin::FigureArgs),
}

/// Runs a `porelab sweep` command.
pub fn cli(args: &SweepArgs) -> Result<ExitCode> {
    match &args.action {
        SweepAction::Plan { sweep, out } => plan::cli_plan(sweep, out).map(|_| ExitCode::SUCCESS),
        SweepAction::Run {
            dir,
            jobs,
            threads,
            retry_failed,
        } => run::cli_run(dir, *jobs, *threads, *retry_failed),
        SweepAction::Job {
            dir,
            index,
            threads,
            requeue,
        } => run::cli_job(dir, *index, *threads, *requeue),
        SweepAction::Slurm(a) => slurm::cli_slurm(a),
        SweepAction::Status { dir } => status::cli_status(dir),
        SweepAction::Collect { dir, partial } => cli_collect(dir, *partial),
        SweepAction::Figure(a) => builtin::cli_figure(a),
    }
}

/// Refuses a count option of 0.
fn at_least_one(value: usize, option: &str) -> Result<()> {
    if value == 0 {
        return invalid(format!("--{option} 0: must be at least 1"));
    }
    Ok(())
}

/// `porelab sweep collect DIR`: writes `collect-missing.txt`, then `collected.csv` and the
/// plots, unless the set is partial, mixed-version or mixed-kind ([`collect::Collected::refusal`])
/// and `partial` is false; then it returns the refusal as an error.
pub fn cli_collect(dir: &Path, partial: bool) -> Result<ExitCode> {
    let c = collect::collect(dir)?;
    let mut missing = String::new();
    for m in &c.missing {
        missing += m;
        missing.push('\n');
    }
    write_atomic(&dir.join("collect-missing.txt"), missing.as_bytes())?;
    if !c.missing.is_empty() {
        eprintln!(
            "  {} job(s) not in the table (also in {}):",
            c.missing.len(),
            dir.join("collect-missing.txt").display()
        );
        for m in &c.missing {
            eprintln!("  {m}");
        }
    }
    let refusal = c.refusal();
    if let (Some(why), false) = (&refusal, partial) {
        return Err(Error::Validation(format!(
            "porelab sweep collect {}: refused: {why}; --partial writes the table of the \
             finished, converged jobs anyway",
            dir.display()
        )));
    }
    write_atomic(&dir.join("collected.csv"), c.csv().as_bytes())?;
    let plots = plots::write_plots(dir, &c)?;
    eprintln!(
        "porelab sweep collect: {} points, {} quantities -> {}; {plots} plots in {}{}",
        c.rows.len(),
        c.quantities.len(),
        dir.join("collected.csv").display(),
        dir.join("plots").display(),
        if refusal.is_some() { " (partial)" } else { "" }
    );
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests;
