//! `porelab sweep status DIR`: how many jobs are done, running, failed, timed out, cancelled,
//! killed and pending; exit code 1 when any failed.

use super::{job_state, JobState, Plan};
use crate::error::Result;
use std::path::Path;
use std::process::ExitCode;

/// Counts of the job states of a sweep, with the jobs that need a word.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Counts {
    pub done: usize,
    pub pending: usize,
    /// Jobs held by a live process, with the process.
    pub running: Vec<(usize, String)>,
    pub failed: Vec<(usize, String)>,
    pub timed_out: Vec<usize>,
    /// Cancelled or stopped by a signal, with the reason.
    pub cancelled: Vec<(usize, String)>,
    /// Killed without a record (SIGKILL, a lost node).
    pub killed: Vec<usize>,
}

/// Reads the state of every job of the sweep in `dir`.
pub fn counts(dir: &Path, plan: &Plan) -> Counts {
    let mut c = Counts::default();
    for j in &plan.jobs {
        match job_state(dir, j.job) {
            JobState::Done => c.done += 1,
            JobState::Pending => c.pending += 1,
            JobState::Running(who) => c.running.push((j.job, who)),
            JobState::Failed(m) => c.failed.push((j.job, m)),
            JobState::TimedOut => c.timed_out.push(j.job),
            JobState::Cancelled(r) => c.cancelled.push((j.job, r)),
            JobState::Killed => c.killed.push(j.job),
        }
    }
    c
}

impl Counts {
    /// "N done, N running, N failed, N timed out, N cancelled, N killed, N pending of M".
    pub fn line(&self, jobs: usize) -> String {
        format!(
            "{} done, {} running, {} failed, {} timed out, {} cancelled, {} killed, {} pending \
             (of {jobs} jobs)",
            self.done,
            self.running.len(),
            self.failed.len(),
            self.timed_out.len(),
            self.cancelled.len(),
            self.killed.len(),
            self.pending
        )
    }
}

/// Prints the counts and every job that is not done or pending; exit code 1 when any failed.
pub fn cli_status(dir: &Path) -> Result<ExitCode> {
    let plan = Plan::read(dir)?;
    let c = counts(dir, &plan);
    println!(
        "{} ({} points): {}",
        dir.display(),
        plan.points(),
        c.line(plan.jobs.len())
    );
    for (j, who) in &c.running {
        println!("  job {j:05} running: {who}");
    }
    for (j, m) in &c.failed {
        println!("  job {j:05} failed: {m}");
    }
    for j in &c.timed_out {
        println!("  job {j:05} timed out: the next run resumes it from its checkpoint");
    }
    for (j, r) in &c.cancelled {
        println!("  job {j:05} {r}: the next run resumes it from its checkpoint");
    }
    for j in &c.killed {
        println!("  job {j:05} killed (no record): the next run resumes it from its checkpoint");
    }
    if !c.failed.is_empty() {
        println!(
            "  (`sweep run --retry-failed` or `sweep slurm --retry-failed` runs failed jobs again)"
        );
    }
    Ok(if c.failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
