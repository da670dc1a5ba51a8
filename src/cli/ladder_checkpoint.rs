//! `checkpoint.json` of `porelab permeability --out`: the ladder's finished rungs (their
//! results; the fields of the last one, which the finest rung's `fields.vtk` needs) and the
//! running rung's steady state ([`crate::lbm::checkpoint`]) with the mean velocities of its
//! last checks (the rung's stop rule projects from the last three). Written atomically when a
//! rung ends and at the running rung's checks (at most every `--checkpoint-every` seconds); a
//! rerun with the same arguments, packing file and `--out` takes the finished rungs as they
//! were and restores the running one before its first step, and ends with bitwise the outputs
//! of an uninterrupted ladder (wall times excepted). A checkpoint of other arguments or
//! another packing is refused, naming it. Removed once the outputs are written.

use crate::driver::Hooks;
use crate::error::{Error, Result};
use crate::io::{fnv1a64, write_atomic};
use crate::lbm::checkpoint::{LbmState, PoreResultState};
use crate::lbm::ladder::{RungRun, RungStore};
use crate::lbm::{Lbm, SteadyBar};
use crate::scene::{read_checkpoint_of, remove_checkpoint};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Format 1: the first.
const FORMAT: u32 = 1;

/// The checks of the running rung whose mean velocities the stop rule reads.
const CHECKS_KEPT: usize = 3;

#[derive(Serialize, Deserialize)]
struct KeptRung {
    result: PoreResultState,
    settled: bool,
    seconds: u64,
    darcy_change: u64,
}

#[derive(Serialize, Deserialize)]
struct Running {
    cells: usize,
    /// Mean velocity along x at the last checks (bits), oldest first.
    checks: Vec<u64>,
    state: LbmState,
}

#[derive(Serialize, Deserialize)]
struct File {
    format: u32,
    /// Hash of the arguments the rungs depend on and of the packing file's bytes.
    ladder: String,
    rungs: Vec<KeptRung>,
    running: Option<Running>,
}

/// [`File`] as written, borrowing the kept rungs (they may hold a rung's fields).
#[derive(Serialize)]
struct FileRef<'a> {
    format: u32,
    ladder: &'a str,
    rungs: &'a [KeptRung],
    running: Option<&'a Running>,
}

/// The ladder's store: progress bars, and with a folder its checkpoint there.
pub struct LadderCheckpoint {
    /// None: nothing kept (no `--out`).
    path: Option<PathBuf>,
    ladder: String,
    rungs: Vec<KeptRung>,
    saved: Option<Running>,
    quiet: bool,
    bar: Option<SteadyBar>,
    every_s: f64,
    last_write: Instant,
    /// The running rung's cells and the mean velocities along x at its last checks.
    cells: usize,
    checks: Vec<f64>,
}

impl LadderCheckpoint {
    /// Progress bars only: no checkpoint.
    pub fn none(quiet: bool) -> LadderCheckpoint {
        LadderCheckpoint {
            path: None,
            ladder: String::new(),
            rungs: Vec::new(),
            saved: None,
            quiet,
            bar: None,
            every_s: 0.0,
            last_write: Instant::now(),
            cells: 0,
            checks: Vec::new(),
        }
    }

    /// The store of the ladder `key` (the arguments its rungs depend on, and the packing
    /// file's bytes) in `out`, holding what an earlier process saved there (refused, naming
    /// the file, when another ladder wrote it). `every_s`: seconds between a running rung's
    /// checkpoints.
    pub fn open(out: &Path, key: &[u8], every_s: f64, quiet: bool) -> Result<LadderCheckpoint> {
        // a killed ladder's half-written files go
        crate::io::remove_stale_temporaries(out)?;
        let path = out.join("checkpoint.json");
        let ladder = format!("{:016x}", fnv1a64(key));
        let saved: Option<File> = read_checkpoint_of(
            &path,
            FORMAT,
            "permeability ladder",
            (&ladder, |f: &File| &f.ladder),
            "a different ladder (other arguments or another packing file)",
        )?;
        let (rungs, running) = saved.map_or((Vec::new(), None), |f| (f.rungs, f.running));
        Ok(LadderCheckpoint {
            path: Some(path),
            ladder,
            rungs,
            saved: running,
            every_s,
            ..LadderCheckpoint::none(quiet)
        })
    }

    /// The rungs kept from an earlier process, and the cells of the rung it was running.
    pub fn resumes(&self) -> Option<(usize, Option<usize>)> {
        (!self.rungs.is_empty() || self.saved.is_some())
            .then(|| (self.rungs.len(), self.saved.as_ref().map(|r| r.cells)))
    }

    fn named(&self, msg: String) -> Error {
        Error::File {
            path: self
                .path
                .as_ref()
                .map_or(String::new(), |p| p.display().to_string()),
            msg,
        }
    }

    fn write(&self, running: Option<Running>) -> Result<()> {
        let Some(path) = &self.path else {
            return Ok(());
        };
        let f = FileRef {
            format: FORMAT,
            ladder: &self.ladder,
            rungs: &self.rungs,
            running: running.as_ref(),
        };
        let bytes = serde_json::to_vec(&f).map_err(|e| Error::InvalidInput(e.to_string()))?;
        write_atomic(path, &bytes)
    }

    /// Removes the file (the outputs are complete).
    pub fn remove(&self) -> Result<()> {
        self.path.as_deref().map_or(Ok(()), remove_checkpoint)
    }
}

impl RungStore for LadderCheckpoint {
    fn finished(&mut self, n: usize) -> Result<Option<RungRun>> {
        let i = self.rungs.iter().position(|r| r.result.n == n);
        let Some(kept) = i.map(|i| &self.rungs[i]) else {
            return Ok(None);
        };
        let f = f64::from_bits;
        Ok(Some(RungRun {
            result: kept.result.result(),
            settled: kept.settled,
            seconds: f(kept.seconds),
            darcy_change: f(kept.darcy_change),
        }))
    }

    fn start(&mut self, n: usize) -> Vec<f64> {
        self.bar = Some(SteadyBar::new(self.quiet));
        self.cells = n;
        self.checks = match &self.saved {
            Some(r) if r.cells == n => r.checks.iter().map(|&b| f64::from_bits(b)).collect(),
            _ => Vec::new(),
        };
        self.checks.clone()
    }

    fn ended(&mut self, run: &RungRun) -> Result<()> {
        self.bar = None;
        self.saved = None;
        // only the last rung's fields are kept: the finest rung's are written out
        if let Some(last) = self.rungs.last_mut() {
            last.result.fields = None;
        }
        self.rungs.push(KeptRung {
            result: PoreResultState::of(&run.result, self.path.is_some()),
            settled: run.settled,
            seconds: run.seconds.to_bits(),
            darcy_change: run.darcy_change.to_bits(),
        });
        self.write(None)?;
        self.last_write = Instant::now();
        Ok(())
    }
}

impl Hooks<Lbm> for LadderCheckpoint {
    fn progress(&mut self, lbm: &Lbm, done: Option<f64>, status: &str) {
        if let Some(b) = &mut self.bar {
            b.progress(lbm, done, status);
        }
    }

    fn checkpoint(&mut self, lbm: &Lbm) -> Result<()> {
        let Some(u) = lbm.checked_mean_u() else {
            return Ok(());
        };
        self.checks.push(u[0]);
        if self.checks.len() > CHECKS_KEPT {
            self.checks.remove(0);
        }
        if self.path.is_none() || self.last_write.elapsed().as_secs_f64() < self.every_s {
            return Ok(());
        }
        let Some(state) = lbm.save_state() else {
            return Ok(());
        };
        self.write(Some(Running {
            cells: self.cells,
            checks: self.checks.iter().map(|x| x.to_bits()).collect(),
            state,
        }))?;
        self.last_write = Instant::now();
        Ok(())
    }

    fn restore(&mut self, lbm: &mut Lbm) -> Result<()> {
        match self.saved.take() {
            Some(r) if r.cells == self.cells => lbm
                .load_state(&r.state)
                .map_err(|e| self.named(format!("rung of {} cells: {e}", r.cells))),
            Some(r) => Err(self.named(format!(
                "holds a running rung of {} cells, but the ladder resumes at {} cells",
                r.cells, self.cells
            ))),
            None => Ok(()),
        }
    }
}
