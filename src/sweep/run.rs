//! `porelab sweep job DIR i` (one job: what a Slurm array task runs) and `porelab sweep run
//! DIR --jobs K` (the unfinished jobs on this machine, K child processes of this binary, so a
//! job's panic or memory stays in its own process).
//!
//! A job runs into `jobs/NNNNN/tmp-<pid>/`; on success that folder is renamed to `out/` and
//! then `done.json` is written (temp file + rename), so `done.json` exists only beside a
//! complete `out/`. A killed job leaves a `tmp-*` folder and no record: the next attempt
//! removes it and starts the job again.

use super::{at_least_one, job_dir, job_state, unfinished, JobState, Plan};
use crate::error::{Error, Result};
use crate::io::write_atomic;
use std::path::Path;
use std::process::{Command, ExitCode, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// What became of one job.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// Ran now (seconds of wall time) or was already done (None).
    Done(Option<f64>),
    Failed(String),
}

/// Removes what an earlier attempt left in `d`: `tmp-*` folders of a killed one, an `out/`
/// without `done.json` (killed between the rename and the record), a `failed.json`.
fn clean_stale(d: &Path) -> Result<()> {
    for e in std::fs::read_dir(d)? {
        let e = e?;
        let name = e.file_name().to_string_lossy().into_owned();
        if name.starts_with("tmp-") || name == "out" {
            std::fs::remove_dir_all(e.path())?;
        }
    }
    match std::fs::remove_file(d.join("failed.json")) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e.into()),
        _ => Ok(()),
    }
}

/// The panic payload as text.
fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".into())
}

/// Runs job `i` of the sweep in `dir` in this process (a job already done is left as it is).
pub fn run_job(dir: &Path, plan: &Plan, i: usize, threads: Option<usize>) -> Result<Outcome> {
    let job = plan.job(i)?;
    let d = job_dir(dir, i);
    if job_state(dir, i) == JobState::Done {
        return Ok(Outcome::Done(None));
    }
    clean_stale(&d)?;
    let started = Instant::now();
    let scene_path = d.join("scene.toml");
    let tmp = d.join(format!("tmp-{}", std::process::id()));
    let attempt = || -> Result<()> {
        let text = std::fs::read_to_string(&scene_path).map_err(|e| Error::File {
            path: scene_path.display().to_string(),
            msg: e.to_string(),
        })?;
        let hash = super::fnv1a64(text.as_bytes());
        if hash != job.hash {
            return Err(Error::File {
                path: scene_path.display().to_string(),
                msg: format!(
                    "changed after planning (FNV-1a 64 {hash:016x}, manifest {:016x}); plan \
                     the sweep again into a new folder",
                    job.hash
                ),
            });
        }
        let opts = crate::scene::RunOptions {
            out: Some(tmp.clone()),
            threads,
            quiet: true,
            // As `porelab run`'s default: a killed job restarts from its scene anyway.
            checkpoint_every_seconds: Some(10.0),
        };
        crate::scene::run_text(&text, &scene_path.display().to_string(), "job", &opts)
    };
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(attempt))
        .unwrap_or_else(|p| Err(Error::Validation(format!("panic: {}", panic_text(&*p)))));
    let seconds = started.elapsed().as_secs_f64();
    let finish = || -> Result<()> {
        std::fs::create_dir_all(&tmp)?;
        std::fs::rename(&tmp, d.join("out"))?;
        let record = serde_json::json!({
            "job": i, "point": job.point, "run": job.run, "seed": job.seed,
            "scene_fnv1a64": format!("{:016x}", job.hash), "seconds": seconds,
        });
        write_atomic(&d.join("done.json"), record.to_string().as_bytes())
    };
    match result.and_then(|_| finish()) {
        Ok(()) => Ok(Outcome::Done(Some(seconds))),
        Err(e) => {
            let _ = std::fs::remove_dir_all(&tmp);
            let msg = e.to_string();
            let record = serde_json::json!({
                "job": i, "point": job.point, "run": job.run, "error": msg, "seconds": seconds,
            });
            write_atomic(&d.join("failed.json"), record.to_string().as_bytes())?;
            Ok(Outcome::Failed(msg))
        }
    }
}

/// `porelab sweep job DIR i`: exit code 0 when the job is done, 1 when it failed.
pub fn cli_job(dir: &Path, i: usize, threads: Option<usize>) -> Result<ExitCode> {
    crate::scene::check_threads(threads)?;
    let plan = Plan::read(dir)?;
    match run_job(dir, &plan, i, threads)? {
        Outcome::Done(s) => {
            match s {
                Some(s) => eprintln!("porelab sweep job {i:05}: done ({s:.2} s)"),
                None => eprintln!("porelab sweep job {i:05}: already done"),
            }
            Ok(ExitCode::SUCCESS)
        }
        Outcome::Failed(msg) => {
            eprintln!("porelab sweep job {i:05}: FAILED: {msg}");
            Ok(ExitCode::from(1))
        }
    }
}

/// Runs job `i` in a child process of this binary, its output in `jobs/NNNNN/log.txt`.
fn run_child(exe: &Path, dir: &Path, i: usize, threads: usize) -> Result<()> {
    let log = std::fs::File::create(job_dir(dir, i).join("log.txt"))?;
    let status = Command::new(exe)
        .args(["sweep", "job"])
        .arg(dir)
        .arg(i.to_string())
        .args(["--threads", &threads.to_string()])
        .stdin(Stdio::null())
        .stdout(log.try_clone()?)
        .stderr(log)
        .status()?;
    if status.success() || matches!(job_state(dir, i), JobState::Done | JobState::Failed(_)) {
        return Ok(());
    }
    // Ended by a signal (Ctrl-C, kill, the out-of-memory killer) before any record: left for
    // the next run, which removes its tmp folder and starts it again.
    #[cfg(unix)]
    if std::os::unix::process::ExitStatusExt::signal(&status).is_some() {
        return Ok(());
    }
    // Any other exit without a record is a failure of its own.
    let record = serde_json::json!({
        "job": i, "error": format!("the job's process ended with {status} and no record"),
    });
    write_atomic(
        &job_dir(dir, i).join("failed.json"),
        record.to_string().as_bytes(),
    )?;
    Ok(())
}

/// `porelab sweep run DIR --jobs K`: the unfinished jobs, K at a time; exit code 1 when any
/// job of the sweep is not done at the end (failed, or interrupted).
pub fn cli_run(
    dir: &Path,
    k: usize,
    threads: Option<usize>,
    retry_failed: bool,
) -> Result<ExitCode> {
    at_least_one(k, "jobs")?;
    crate::scene::check_threads(threads)?;
    let plan = Plan::read(dir)?;
    let todo = unfinished(dir, &plan, retry_failed);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads = threads.unwrap_or((cores / k).max(1));
    let exe = std::env::current_exe()?;
    eprintln!(
        "porelab sweep run {}: {} of {} jobs to run, {k} at a time, {threads} threads each",
        dir.display(),
        todo.len(),
        plan.jobs.len()
    );
    let next = AtomicUsize::new(0);
    let errors = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..k.min(todo.len()) {
            s.spawn(|| loop {
                let n = next.fetch_add(1, Ordering::SeqCst);
                let Some(&i) = todo.get(n) else { break };
                let started = Instant::now();
                if let Err(e) = run_child(&exe, dir, i, threads) {
                    errors
                        .lock()
                        .expect("no panics hold it")
                        .push(format!("job {i:05}: {e}"));
                }
                let took = started.elapsed().as_secs_f64();
                match job_state(dir, i) {
                    JobState::Done => eprintln!("  job {i:05} done ({took:.2} s)"),
                    JobState::Failed(m) => eprintln!("  job {i:05} FAILED: {m}"),
                    _ => eprintln!(
                        "  job {i:05} interrupted (its process was killed); the next run \
                         starts it again"
                    ),
                }
            });
        }
    });
    let errors = errors.into_inner().expect("no panics hold it");
    if let Some(e) = errors.first() {
        return Err(Error::Validation(format!(
            "could not start {} job(s); first: {e}",
            errors.len()
        )));
    }
    let c = super::status::counts(dir, &plan);
    let failed = c.failed.len();
    eprintln!(
        "porelab sweep run: {} of {} done, {failed} failed, {} not run or interrupted{}",
        c.done,
        plan.jobs.len(),
        c.started + c.pending,
        if failed > 0 {
            " (`porelab sweep status` shows why; --retry-failed runs them again)"
        } else {
            ""
        }
    );
    Ok(if c.done < plan.jobs.len() {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}
