//! `porelab sweep job DIR i` (one job: what a Slurm array task runs) and `porelab sweep run
//! DIR --jobs K` (the unfinished jobs on this machine, K child processes of this binary, so a
//! job's panic or memory stays in its own process).
//!
//! A job first claims its folder ([`super::claim`]): a job that another live process holds is
//! left to it. It then runs into `jobs/NNNNN/work/`, which is never removed before the job is
//! done, so a retried, requeued or timed-out job resumes from the checkpoint there (packing,
//! DEM and coupled scenes). On success (the scene returned and wrote `summary.json`) `work/` is
//! renamed to `out/` and then `done.json` is written (temp file + rename), so `done.json`
//! exists only beside complete outputs; `failed.json` and `interrupted.json` are removed
//! before, and never written beside `done.json` (the claim makes the job folder this process's
//! alone).
//!
//! Signals: SIGUSR1 (Slurm's `--signal` before the time limit), SIGTERM and SIGINT ask the
//! scene to stop at its next check, which writes its checkpoint; the job then writes
//! `interrupted.json` (reason "timed out" for SIGUSR1 or a Slurm job in state TIMEOUT,
//! otherwise "cancelled ...") and exits 128 + the signal. A scene without checkpoints that
//! does not stop within [`GRACE`] is ended the same way (Slurm's KillWait is 30 s by default).

use super::claim::{try_claim, Claimed};
use super::{at_least_one, job_dir, job_state, unfinished, JobState, Plan};
use crate::error::{Error, Result};
use crate::io::write_atomic;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::sync::atomic::{AtomicI32, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// The record of an interrupted job (its `reason`).
pub const INTERRUPTED: &str = "interrupted.json";
/// The `reason` of a job stopped at or warned of its time limit.
pub const TIMED_OUT: &str = "timed out";
/// How long a signalled job waits for its scene to stop before it ends itself.
pub const GRACE: Duration = Duration::from_secs(20);

/// What became of one job.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// Ran now (seconds of wall time) or was already done (None).
    Done(Option<f64>),
    Failed(String),
    /// Stopped by a signal: the reason written to `interrupted.json`.
    Interrupted(String),
    /// Another live process holds the job (it is described).
    Elsewhere(String),
}

/// The signal that asked this process to stop (0: none yet).
static SIGNAL: AtomicI32 = AtomicI32::new(0);

extern "C" fn on_signal(sig: libc::c_int) {
    // async-signal-safe: atomic stores only
    SIGNAL.store(sig, Ordering::SeqCst);
    crate::driver::signal_stop();
}

/// Routes SIGTERM, SIGINT and SIGUSR1 to [`SIGNAL`] and the drivers' stop flag.
fn install_stop_handlers() {
    for sig in [libc::SIGTERM, libc::SIGINT, libc::SIGUSR1] {
        // SAFETY: the handler only stores to atomics.
        unsafe {
            libc::signal(sig, on_signal as *const () as libc::sighandler_t);
        }
    }
}

/// The signal received, if any.
fn signalled() -> Option<i32> {
    Some(SIGNAL.load(Ordering::SeqCst)).filter(|&s| s != 0)
}

fn signal_name(sig: i32) -> &'static str {
    match sig {
        libc::SIGTERM => "SIGTERM",
        libc::SIGINT => "SIGINT",
        libc::SIGUSR1 => "SIGUSR1",
        _ => "a signal",
    }
}

/// Why the job was stopped: "timed out" for Slurm's time-limit warning (SIGUSR1) or a Slurm
/// job whose state is TIMEOUT; otherwise "cancelled (SIGTERM)" and the like.
fn interruption_reason(sig: i32) -> String {
    if sig == libc::SIGUSR1 {
        return TIMED_OUT.into();
    }
    if let Ok(id) = std::env::var("SLURM_JOB_ID") {
        let show = Command::new("scontrol")
            .args(["show", "job", &id])
            .output()
            .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
            .unwrap_or_default();
        if show.contains("JobState=TIMEOUT") || show.contains("Reason=TimeLimit") {
            return TIMED_OUT.into();
        }
    }
    format!("cancelled ({})", signal_name(sig))
}

/// Removes `path` if it exists.
fn remove_if_there(path: &Path) -> Result<()> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(Error::File {
            path: path.display().to_string(),
            msg: e.to_string(),
        }),
        _ => Ok(()),
    }
}

/// Removes what an attempt of an older porelab left: `tmp-*` folders (they held no
/// checkpoint a resume could use).
fn clean_legacy(d: &Path) -> Result<()> {
    for e in std::fs::read_dir(d)? {
        let e = e?;
        if e.file_name().to_string_lossy().starts_with("tmp-") {
            std::fs::remove_dir_all(e.path())?;
        }
    }
    Ok(())
}

/// The panic payload as text.
fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".into())
}

/// Writes `done.json` for job `i` (its `out/` is complete).
fn write_done(d: &Path, plan: &Plan, i: usize, seconds: Option<f64>) -> Result<()> {
    let job = &plan.jobs[i];
    let record = serde_json::json!({
        "job": i, "point": job.point, "run": job.run, "seed": job.seed,
        "scene_fnv1a64": format!("{:016x}", job.hash), "seconds": seconds,
        "porelab_version": env!("CARGO_PKG_VERSION"),
    });
    write_atomic(&d.join("done.json"), record.to_string().as_bytes())
}

/// Writes a job record (`failed.json`, `interrupted.json`) with `field` = `text`.
fn write_record(
    d: &Path,
    plan: &Plan,
    i: usize,
    file: &str,
    field: &str,
    text: &str,
) -> Result<()> {
    let job = &plan.jobs[i];
    let mut record = serde_json::json!({ "job": i, "point": job.point, "run": job.run });
    record[field] = serde_json::Value::String(text.to_string());
    write_atomic(&d.join(file), record.to_string().as_bytes())
}

/// Runs job `i` of the sweep in `dir` in this process (a job already done is left as it is,
/// and so is one that another live process holds).
pub fn run_job(dir: &Path, plan: &Plan, i: usize, threads: Option<usize>) -> Result<Outcome> {
    let job = plan.job(i)?;
    let d = job_dir(dir, i);
    if job_state(dir, i) == JobState::Done {
        return Ok(Outcome::Done(None));
    }
    let _claim = match try_claim(&d)? {
        Claimed::Mine(c) => c,
        Claimed::Held(o) => return Ok(Outcome::Elsewhere(o.describe())),
    };
    // Under the claim: the folder is this process's alone.
    if d.join("done.json").is_file() {
        return Ok(Outcome::Done(None));
    }
    if d.join("out").join("summary.json").is_file() {
        // killed between the rename of complete outputs and the record
        write_done(&d, plan, i, None)?;
        return Ok(Outcome::Done(None));
    }
    clean_legacy(&d)?;
    let stray_out = d.join("out");
    if stray_out.exists() {
        std::fs::remove_dir_all(&stray_out)?;
    }
    remove_if_there(&d.join("failed.json"))?;
    remove_if_there(&d.join(INTERRUPTED))?;
    let work = d.join("work");
    let checkpoint = work.join("checkpoint.json");
    if work.join("summary.json").is_file() {
        if checkpoint.is_file() {
            // killed after its summary but before its checkpoint was removed: the resumed
            // scene writes both again; a stale summary must not pass for the end of this one
            remove_if_there(&work.join("summary.json"))?;
        } else {
            // killed after its last output, before the rename
            std::fs::rename(&work, d.join("out"))?;
            write_done(&d, plan, i, None)?;
            return Ok(Outcome::Done(None));
        }
    }
    let started = Instant::now();
    let scene_path = d.join("scene.toml");
    if checkpoint.is_file() {
        eprintln!(
            "porelab sweep job {i:05}: resuming from {}",
            checkpoint.display()
        );
    }
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
            out: Some(work.clone()),
            threads,
            quiet: true,
            // As `porelab run`'s default; a signal also writes one (module doc).
            checkpoint_every_seconds: Some(10.0),
        };
        crate::scene::run_text(&text, &scene_path.display().to_string(), "job", &opts)
    };
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(attempt))
        .unwrap_or_else(|p| Err(Error::Validation(format!("panic: {}", panic_text(&*p)))));
    let seconds = started.elapsed().as_secs_f64();
    let complete = work.join("summary.json").is_file();
    let outcome = match (result, signalled()) {
        (Ok(()), _) if complete => {
            std::fs::rename(&work, d.join("out"))?;
            write_done(&d, plan, i, Some(seconds))?;
            return Ok(Outcome::Done(Some(seconds)));
        }
        // A stopped scene returns Ok (or the error of its interrupted step): the signal decides.
        (_, Some(sig)) => {
            let reason = interruption_reason(sig);
            write_record(&d, plan, i, INTERRUPTED, "reason", &reason)?;
            Outcome::Interrupted(reason)
        }
        (Ok(()), None) => Outcome::Failed(format!(
            "the scene returned without writing {}",
            work.join("summary.json").display()
        )),
        (Err(e), None) => Outcome::Failed(e.to_string()),
    };
    if let Outcome::Failed(msg) = &outcome {
        write_record(&d, plan, i, "failed.json", "error", msg)?;
    }
    Ok(outcome)
}

/// Ends this `sweep job` process when its scene has not stopped [`GRACE`] after a signal
/// (scenes without checkpoints do not look at the stop flag): records the interruption
/// (the checkpoint on disk is the last periodic one) and exits 128 + the signal.
fn spawn_watchdog(d: PathBuf, plan: Plan, i: usize) {
    std::thread::spawn(move || {
        let sig = loop {
            if let Some(s) = signalled() {
                break s;
            }
            std::thread::sleep(Duration::from_millis(100));
        };
        std::thread::sleep(GRACE);
        let reason = interruption_reason(sig);
        let _ = write_record(&d, &plan, i, INTERRUPTED, "reason", &reason);
        let _ = std::fs::remove_file(d.join(super::claim::CLAIM));
        eprintln!(
            "porelab sweep job {i:05}: {reason}; the scene did not stop within {} s",
            GRACE.as_secs()
        );
        std::process::exit(128 + sig);
    });
}

/// Asks Slurm to requeue this array task (after a time-limit warning): the requeued task
/// resumes from the checkpoint.
fn requeue_self() -> Result<()> {
    let (Ok(array), Ok(task)) = (
        std::env::var("SLURM_ARRAY_JOB_ID"),
        std::env::var("SLURM_ARRAY_TASK_ID"),
    ) else {
        return Err(Error::Validation(
            "--requeue: not a Slurm array task (no SLURM_ARRAY_JOB_ID)".into(),
        ));
    };
    let id = format!("{array}_{task}");
    let out = Command::new("scontrol").args(["requeue", &id]).output()?;
    if !out.status.success() {
        return Err(Error::Validation(format!(
            "scontrol requeue {id} failed: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    Ok(())
}

/// `porelab sweep job DIR i`: exit code 0 when the job is done (or held by another live
/// process), 1 when it failed, 128 + the signal when a signal stopped it. With `requeue`, a
/// job stopped at its time limit asks Slurm to requeue it.
pub fn cli_job(dir: &Path, i: usize, threads: Option<usize>, requeue: bool) -> Result<ExitCode> {
    crate::scene::check_threads(threads)?;
    let plan = Plan::read(dir)?;
    plan.job(i)?;
    install_stop_handlers();
    spawn_watchdog(job_dir(dir, i), plan.clone(), i);
    match run_job(dir, &plan, i, threads)? {
        Outcome::Done(s) => {
            match s {
                Some(s) => eprintln!("porelab sweep job {i:05}: done ({s:.2} s)"),
                None => eprintln!("porelab sweep job {i:05}: already done"),
            }
            Ok(ExitCode::SUCCESS)
        }
        Outcome::Elsewhere(who) => {
            eprintln!("porelab sweep job {i:05}: running in {who}; left to it");
            Ok(ExitCode::SUCCESS)
        }
        Outcome::Failed(msg) => {
            eprintln!("porelab sweep job {i:05}: FAILED: {msg}");
            Ok(ExitCode::from(1))
        }
        Outcome::Interrupted(reason) => {
            eprintln!(
                "porelab sweep job {i:05}: {reason}; checkpoint kept in {}",
                job_dir(dir, i).join("work").display()
            );
            if requeue && reason == TIMED_OUT {
                requeue_self()?;
                eprintln!("porelab sweep job {i:05}: requeued");
            }
            let sig = signalled().unwrap_or(libc::SIGTERM);
            Ok(ExitCode::from((128 + sig) as u8))
        }
    }
}

/// The job processes of `sweep run` now running (pids), so a signal can end them.
static CHILDREN: Mutex<Vec<u32>> = Mutex::new(Vec::new());

/// Runs job `i` in a child process of this binary, its output in `jobs/NNNNN/log.txt`. The
/// child gets SIGTERM when this process dies (Linux PR_SET_PDEATHSIG), even by SIGKILL.
fn run_child(exe: &Path, dir: &Path, i: usize, threads: usize) -> Result<()> {
    let log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(job_dir(dir, i).join("log.txt"))?;
    let mut cmd = Command::new(exe);
    cmd.args(["sweep", "job"])
        .arg(dir)
        .arg(i.to_string())
        .args(["--threads", &threads.to_string()])
        .stdin(Stdio::null())
        .stdout(log.try_clone()?)
        .stderr(log);
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::process::CommandExt;
        // SAFETY: prctl is async-signal-safe; nothing else runs between fork and exec.
        unsafe {
            cmd.pre_exec(|| {
                libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM);
                Ok(())
            });
        }
    }
    let mut child = cmd.spawn()?;
    let pid = child.id();
    CHILDREN.lock().map_err(|_| poisoned())?.push(pid);
    let status = child.wait();
    CHILDREN
        .lock()
        .map_err(|_| poisoned())?
        .retain(|&p| p != pid);
    let status = status?;
    let state = job_state(dir, i);
    if status.success() || !matches!(state, JobState::Killed | JobState::Pending) {
        return Ok(());
    }
    // Ended by a signal (kill -9, the out-of-memory killer) before any record: left for the
    // next run, which resumes it.
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

fn poisoned() -> Error {
    Error::Validation("a job thread panicked".into())
}

/// Sends SIGTERM to every job process of this `sweep run` once a signal arrived; each writes
/// its checkpoint and `interrupted.json`.
fn spawn_stopper() {
    std::thread::spawn(|| {
        while signalled().is_none() {
            std::thread::sleep(Duration::from_millis(100));
        }
        if let Ok(children) = CHILDREN.lock() {
            for &pid in children.iter() {
                // SAFETY: plain kill(2) of a child this process started and still waits for.
                unsafe {
                    libc::kill(pid as libc::pid_t, libc::SIGTERM);
                }
            }
        }
    });
}

/// `porelab sweep run DIR --jobs K`: the unfinished jobs, K at a time; exit code 1 when any
/// job of the sweep is not done at the end (failed, interrupted, or running elsewhere), 128 +
/// the signal when SIGINT or SIGTERM stopped it (its job processes are stopped too and resume
/// on the next run).
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
    install_stop_handlers();
    spawn_stopper();
    let next = AtomicUsize::new(0);
    let errors = Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..k.min(todo.len()) {
            s.spawn(|| loop {
                if signalled().is_some() {
                    break;
                }
                let n = next.fetch_add(1, Ordering::SeqCst);
                let Some(&i) = todo.get(n) else { break };
                let started = Instant::now();
                if let Err(e) = run_child(&exe, dir, i, threads) {
                    if let Ok(mut errors) = errors.lock() {
                        errors.push(format!("job {i:05}: {e}"));
                    }
                }
                let took = started.elapsed().as_secs_f64();
                match job_state(dir, i) {
                    JobState::Done => eprintln!("  job {i:05} done ({took:.2} s)"),
                    JobState::Failed(m) => eprintln!("  job {i:05} FAILED: {m}"),
                    JobState::Running(who) => {
                        eprintln!("  job {i:05} is running in {who}; left to it")
                    }
                    other => eprintln!(
                        "  job {i:05} {} (its process was stopped); the next run resumes it",
                        other.name()
                    ),
                }
            });
        }
    });
    let errors = errors.into_inner().map_err(|_| poisoned())?;
    if let Some(e) = errors.first() {
        return Err(Error::Validation(format!(
            "could not start {} job(s); first: {e}",
            errors.len()
        )));
    }
    let c = super::status::counts(dir, &plan);
    eprintln!("porelab sweep run: {}", c.line(plan.jobs.len()));
    if let Some(sig) = signalled() {
        eprintln!(
            "porelab sweep run: stopped by {}; run it again to resume",
            signal_name(sig)
        );
        return Ok(ExitCode::from((128 + sig) as u8));
    }
    Ok(if c.done < plan.jobs.len() {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}
