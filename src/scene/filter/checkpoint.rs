//! `checkpoint.json` of a filter scene: the hash of the scene text and the particles' state
//! ([`crate::filter::checkpoint`]), written atomically after steps (at most every
//! `--checkpoint-every` seconds) and when the run is stopped (a signal). The run started
//! again with the same scene and `--out` computes the flow through the bed again (the lattice
//! run is deterministic: the same flow to the bit), restores the particles before their first
//! step and ends with bitwise the outputs of an uninterrupted run. Removed once the outputs
//! are written. A run killed while its flow is computed starts afresh.

use crate::driver::Hooks;
use crate::error::Error;
use crate::filter::checkpoint::FilterState;
use crate::filter::Filter;
use crate::io::{fnv1a64, write_atomic};
use crate::scene::{read_checkpoint_file, remove_checkpoint, RunOptions};
use crate::Result;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::time::Instant;

/// Format 1: the first.
const FORMAT: u32 = 1;

#[derive(Serialize, Deserialize)]
struct File {
    format: u32,
    scene: String,
    state: FilterState,
}

/// The hooks of the particles' run: a progress bar, the checkpoint, the stop.
pub(super) struct Resumable {
    path: PathBuf,
    scene: String,
    saved: Option<FilterState>,
    bar: indicatif::ProgressBar,
    every_s: Option<f64>,
    last: Instant,
    /// The run was stopped (its state is in the checkpoint): no outputs.
    pub stopped: bool,
    /// An error of writing the checkpoint at the stop, reported after the run.
    failed: Option<Error>,
}

impl Resumable {
    /// The hooks of the scene `text` writing into `out`, holding the state an earlier process
    /// saved there (refused, naming the file, when another scene wrote it).
    pub fn open(out: &std::path::Path, text: &str, opts: &RunOptions) -> Result<Resumable> {
        opts.check_checkpoint_interval()?;
        let path = out.join("checkpoint.json");
        let scene = format!("{:016x}", fnv1a64(text.as_bytes()));
        let saved = read_checkpoint_file(&path, FORMAT, "filter", &scene, |f: &File| &f.scene)?;
        let bar = if opts.quiet {
            indicatif::ProgressBar::hidden()
        } else {
            let b = indicatif::ProgressBar::new(1000);
            b.set_style(
                indicatif::ProgressStyle::with_template("[{elapsed_precise}] {bar:30} {msg}")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b
        };
        Ok(Resumable {
            path,
            scene,
            saved: saved.map(|f| f.state),
            bar,
            every_s: opts.checkpoint_every_seconds,
            last: Instant::now(),
            stopped: false,
            failed: None,
        })
    }

    fn write(&mut self, f: &Filter) -> Result<()> {
        let file = File {
            format: FORMAT,
            scene: self.scene.clone(),
            state: f.save_state(),
        };
        let bytes = serde_json::to_vec(&file).map_err(|e| Error::InvalidInput(e.to_string()))?;
        write_atomic(&self.path, &bytes)?;
        self.last = Instant::now();
        Ok(())
    }

    /// After the run (the bar removed): the error of the stop's checkpoint, if any; else
    /// whether it was stopped.
    pub fn was_stopped(&mut self) -> Result<bool> {
        self.bar.finish_and_clear();
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

impl Hooks<Filter> for Resumable {
    fn progress(&mut self, _: &Filter, done: Option<f64>, status: &str) {
        if let Some(d) = done {
            self.bar.set_position((1000.0 * d) as u64);
        }
        self.bar.set_message(status.to_string());
    }

    fn checkpoint(&mut self, f: &Filter) -> Result<()> {
        if self
            .every_s
            .is_none_or(|t| self.last.elapsed().as_secs_f64() >= t)
        {
            self.write(f)?;
        }
        Ok(())
    }

    fn restore(&mut self, f: &mut Filter) -> Result<()> {
        let Some(s) = self.saved.take() else {
            return Ok(());
        };
        f.load_state(&s).map_err(|e| Error::File {
            path: self.path.display().to_string(),
            msg: e.to_string(),
        })
    }

    fn stop_requested(&mut self, f: &Filter) -> bool {
        let stop = crate::driver::stop_signalled();
        if stop {
            self.stopped = true;
            if let Err(e) = self.write(f) {
                self.failed = Some(e);
            }
        }
        stop
    }
}
