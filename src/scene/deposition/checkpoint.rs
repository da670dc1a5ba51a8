//! `checkpoint.json` of a deposition scene: the hash of the scene text and, per run, the last
//! saved state of its engine ([`crate::deposition::checkpoint`]) with its wall time so far.
//! The runs go on in parallel; each saves its own slot (at most every `--checkpoint-every`
//! seconds, when it finishes, and when it is stopped) and the whole file is written
//! atomically under one lock, so the file always holds a state of every run that a resumed
//! run continues bitwise. Removed once the outputs are written.

use crate::deposition::checkpoint::DepositionState;
use crate::error::Error;
use crate::io::{fnv1a64, write_atomic};
use crate::scene::{read_checkpoint_file, remove_checkpoint};
use crate::Result;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Format 1: the first.
const FORMAT: u32 = 1;

/// One run's slot.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(super) struct RunCheckpoint {
    /// Wall time of building the start, s (bits).
    pub start_seconds: u64,
    /// Wall time of the run up to this state, s (bits).
    pub seconds: u64,
    pub state: DepositionState,
}

/// The file as read (its `format` is checked by [`read_checkpoint_file`]).
#[derive(Deserialize)]
struct File {
    scene: String,
    runs: Vec<Option<RunCheckpoint>>,
}

/// [`File`] as written (borrowing the slots).
#[derive(Serialize)]
struct FileOut<'a> {
    format: u32,
    scene: &'a str,
    runs: &'a [Option<RunCheckpoint>],
}

/// The checkpoint of one scene's runs, shared by the runs' threads.
pub(super) struct Checkpoints {
    path: PathBuf,
    scene: String,
    runs: Mutex<Vec<Option<RunCheckpoint>>>,
}

impl Checkpoints {
    /// The checkpoint of the scene `text` with `runs` runs in `out`, holding what an earlier
    /// process saved there (refused, naming the file, when another scene wrote it).
    pub fn open(out: &Path, text: &str, runs: usize) -> Result<Checkpoints> {
        let path = out.join("checkpoint.json");
        let scene = format!("{:016x}", fnv1a64(text.as_bytes()));
        let saved = read_checkpoint_file(&path, FORMAT, "deposition", &scene, |f: &File| &f.scene)?;
        let slots = match saved {
            Some(f) if f.runs.len() != runs => {
                return Err(Error::File {
                    path: path.display().to_string(),
                    msg: format!("holds {} runs, the scene has {runs}", f.runs.len()),
                })
            }
            Some(f) => f.runs,
            None => vec![None; runs],
        };
        Ok(Checkpoints {
            path,
            scene,
            runs: Mutex::new(slots),
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The runs an earlier process saved.
    pub fn resumed(&self) -> usize {
        self.lock().iter().flatten().count()
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Option<RunCheckpoint>>> {
        // a run that panicked holding the lock left the slots as they were: still valid
        self.runs.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The saved slot of run `k`.
    pub fn saved(&self, k: usize) -> Option<RunCheckpoint> {
        self.lock().get(k).cloned().flatten()
    }

    /// Saves run `k`'s slot and writes the file.
    pub fn save(&self, k: usize, slot: RunCheckpoint) -> Result<()> {
        let mut runs = self.lock();
        runs[k] = Some(slot);
        let f = FileOut {
            format: FORMAT,
            scene: &self.scene,
            runs: &runs,
        };
        let bytes = serde_json::to_vec(&f).map_err(|e| Error::InvalidInput(e.to_string()))?;
        write_atomic(&self.path, &bytes)
    }

    /// Removes the file (the outputs are complete).
    pub fn remove(&self) -> Result<()> {
        remove_checkpoint(&self.path)
    }
}
