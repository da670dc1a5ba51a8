//! `checkpoint.json` of an LBM scene: the hash of the scene text and the steady run's state
//! ([`crate::lbm::checkpoint`]), written atomically at checks (at most every
//! `--checkpoint-every` seconds) and when the run is stopped (a signal: the driver's stop
//! flag); the run started again with the same scene and `--out` restores it before its first
//! step and ends with bitwise the outputs of an uninterrupted run. Removed once the outputs
//! are written.

use crate::driver::Hooks;
use crate::error::Error;
use crate::io::{fnv1a64, write_atomic};
use crate::lbm::checkpoint::LbmState;
use crate::lbm::{Lbm, SteadyBar};
use crate::scene::{read_checkpoint_file, remove_checkpoint, RunOptions};
use crate::Result;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Format 1: the first.
const FORMAT: u32 = 1;

#[derive(Serialize, Deserialize)]
struct File {
    format: u32,
    scene: String,
    state: LbmState,
}

/// The hooks of a scene's steady run: the progress bar, the checkpoint, the stop.
pub(super) struct Resumable {
    path: PathBuf,
    scene: String,
    saved: Option<LbmState>,
    /// The progress bar, removed when the run returns.
    bar: Option<SteadyBar>,
    every_s: Option<f64>,
    last: Instant,
    /// Tests: stop after this many checks.
    max_checks: Option<u64>,
    checks: u64,
    /// The run was stopped (its state is in the checkpoint): no outputs.
    pub stopped: bool,
    /// An error of writing the checkpoint at the stop, reported after the run.
    failed: Option<Error>,
}

impl Resumable {
    /// The hooks of the scene `text` writing into `out`, holding the state an earlier process
    /// saved there (refused, naming the file, when another scene wrote it).
    pub fn open(
        out: &Path,
        text: &str,
        opts: &RunOptions,
        max_checks: Option<u64>,
    ) -> Result<Resumable> {
        opts.check_checkpoint_interval()?;
        let path = out.join("checkpoint.json");
        let scene = format!("{:016x}", fnv1a64(text.as_bytes()));
        let saved = read_checkpoint_file(&path, FORMAT, "LBM", &scene, |f: &File| &f.scene)?;
        Ok(Resumable {
            path,
            scene,
            saved: saved.map(|f| f.state),
            bar: Some(SteadyBar::new(opts.quiet)),
            every_s: opts.checkpoint_every_seconds,
            last: Instant::now(),
            max_checks,
            checks: 0,
            stopped: false,
            failed: None,
        })
    }

    /// The step a resumed run continues from (None: a fresh start).
    pub fn resumes_at(&self) -> Option<u64> {
        self.saved.as_ref().map(|s| s.steps)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    fn write(&mut self, lbm: &Lbm) -> Result<()> {
        let Some(state) = lbm.save_state() else {
            return Ok(());
        };
        let f = File {
            format: FORMAT,
            scene: self.scene.clone(),
            state,
        };
        let bytes = serde_json::to_vec(&f).map_err(|e| Error::InvalidInput(e.to_string()))?;
        write_atomic(&self.path, &bytes)?;
        self.last = Instant::now();
        Ok(())
    }

    /// After the run (its progress bar is removed): the error of the stop's checkpoint, if
    /// any; else whether it was stopped.
    pub fn was_stopped(&mut self) -> Result<bool> {
        self.bar = None;
        match self.failed.take() {
            Some(e) => Err(e),
            None => Ok(self.stopped),
        }
    }

    /// Removes the file (the outputs are complete).
    pub fn remove(&self) -> Result<()> {
        remove_checkpoint(&self.path)
    }
}

impl Hooks<Lbm> for Resumable {
    fn progress(&mut self, lbm: &Lbm, done: Option<f64>, status: &str) {
        if let Some(b) = &mut self.bar {
            b.progress(lbm, done, status);
        }
    }

    fn checkpoint(&mut self, lbm: &Lbm) -> Result<()> {
        self.checks += 1;
        if self
            .every_s
            .is_none_or(|t| self.last.elapsed().as_secs_f64() >= t)
        {
            self.write(lbm)?;
        }
        Ok(())
    }

    fn restore(&mut self, lbm: &mut Lbm) -> Result<()> {
        let Some(s) = self.saved.take() else {
            return Ok(());
        };
        lbm.load_state(&s).map_err(|e| Error::File {
            path: self.path.display().to_string(),
            msg: e.to_string(),
        })
    }

    fn stop_requested(&mut self, lbm: &Lbm) -> bool {
        let stop =
            self.max_checks.is_some_and(|m| self.checks >= m) || crate::driver::stop_signalled();
        if stop {
            self.stopped = true;
            if let Err(e) = self.write(lbm) {
                self.failed = Some(e);
            }
        }
        stop
    }
}
