//! What every engine's driver (`<engine>/driver.rs`, which runs an engine to its end) tells
//! its caller while it runs, so that a scene, a validation runner or a benchmark gets progress
//! and checkpoints the same way from every engine.

use crate::Result;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set by a signal handler (a sweep job told by Slurm that its time limit is near, or
/// cancelled): scenes with checkpoints stop at their next check as `stop_requested` does,
/// writing the checkpoint.
static STOP_SIGNALLED: AtomicBool = AtomicBool::new(false);

/// Asks every running driver to stop at its next check (async-signal-safe: one atomic store).
pub fn signal_stop() {
    STOP_SIGNALLED.store(true, Ordering::SeqCst);
}

/// True once [`signal_stop`] was called.
pub fn stop_signalled() -> bool {
    STOP_SIGNALLED.load(Ordering::SeqCst)
}

/// The caller's side of a run. Every method has a default that does nothing, so a caller
/// implements only what it needs; [`NoHooks`] implements none.
pub trait Hooks<E: ?Sized> {
    /// Called after each check of the stop rule with the engine, the fraction of the run done
    /// when the driver knows it (None for a run that stops on a criterion), and a one-line
    /// status (e.g. the residual).
    fn progress(&mut self, _engine: &E, _done: Option<f64>, _status: &str) {}

    /// Called where the driver may write a checkpoint (after a check); an error stops the run.
    fn checkpoint(&mut self, _engine: &E) -> Result<()> {
        Ok(())
    }

    /// Called once before the first step by a driver that resumes runs (the LBM's steady run,
    /// the filter's run to its end): a caller holding a checkpoint of this run restores
    /// `engine` from it; an error stops the run.
    fn restore(&mut self, _engine: &mut E) -> Result<()> {
        Ok(())
    }

    /// Asked after each check: true stops the run there, as a kill would (tests of resume).
    fn stop_requested(&mut self, _engine: &E) -> bool {
        false
    }
}

/// Hooks that do nothing: a run to its end with no progress and no checkpoints.
pub struct NoHooks;

impl<E: ?Sized> Hooks<E> for NoHooks {}
