//! `porelab sweep status DIR`: how many jobs are done, failed, started and pending.

use super::{job_state, JobState, Plan};
use crate::error::Result;
use std::path::Path;

/// Counts of the job states of a sweep, and the failed jobs with their messages.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Counts {
    pub done: usize,
    pub started: usize,
    pub pending: usize,
    pub failed: Vec<(usize, String)>,
}

/// Reads the state of every job of the sweep in `dir`.
pub fn counts(dir: &Path, plan: &Plan) -> Counts {
    let mut c = Counts::default();
    for j in &plan.jobs {
        match job_state(dir, j.job) {
            JobState::Done => c.done += 1,
            JobState::Started => c.started += 1,
            JobState::Pending => c.pending += 1,
            JobState::Failed(m) => c.failed.push((j.job, m)),
        }
    }
    c
}

pub fn cli_status(dir: &Path) -> Result<()> {
    let plan = Plan::read(dir)?;
    let c = counts(dir, &plan);
    println!(
        "{}: {} jobs ({} points): {} done, {} failed, {} started (running, or killed: the next \
         run starts them again), {} pending",
        dir.display(),
        plan.jobs.len(),
        plan.points(),
        c.done,
        c.failed.len(),
        c.started,
        c.pending
    );
    for (j, m) in &c.failed {
        println!("  job {j:05} failed: {m}");
    }
    Ok(())
}
