//! Running an MCM to its end: compression steps until the last stage's halvings (or its budget
//! of moves) are spent or `max_steps` is reached, with the caller's progress, checkpoint and
//! stop hooks ([`Hooks`]) after every step.

use super::engine::{Mcm, McmResult, StepOutcome};
use super::setup::Setup;
use super::Packing;
use crate::driver::{Hooks, NoHooks};
use crate::Result;

/// How a run handed back by [`run`] ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ended {
    /// The schedule ended (jammed, or `max_steps`): [`Mcm::is_done`].
    Finished,
    /// The hooks asked to stop (the checkpoint hook was called first); the run can go on.
    Stopped,
}

/// Runs `mcm` until it is done. Before each step the hooks may stop the run (then the
/// checkpoint hook is called once more and the run returns [`Ended::Stopped`]); after each
/// step the checkpoint hook is called (it decides whether to write), and, while the run goes
/// on, the progress hook with a status line (stage, step, packing fraction, Delta V, halvings
/// left, moves).
pub fn run(mcm: &mut Mcm, hooks: &mut impl Hooks<Mcm>) -> Result<Ended> {
    while !mcm.is_done() {
        if hooks.stop_requested(mcm) {
            hooks.checkpoint(mcm)?;
            return Ok(Ended::Stopped);
        }
        let o = mcm.step()?;
        hooks.checkpoint(mcm)?;
        if o != StepOutcome::Finished {
            hooks.progress(mcm, None, &status(mcm));
        }
    }
    Ok(Ended::Finished)
}

/// The status line of a running MCM.
pub fn status(mcm: &Mcm) -> String {
    let s = mcm.state();
    format!(
        "stage {} step {}  phi = {:.5}  Delta V = {:.3e}  halvings left {}  tries {}",
        s.stage + 1,
        s.history.len(),
        s.packing.packing_fraction(),
        s.delta_v,
        s.halvings_left,
        s.total_tries
    )
}

/// Runs the MCM of `setup` from its random start to its end, without hooks.
pub fn run_to_end(setup: Setup) -> Result<McmResult> {
    finish(Mcm::new(setup)?)
}

/// Runs the MCM of `setup` from the overlap-free configuration `start` to its end.
pub fn run_from(setup: Setup, start: Packing) -> Result<McmResult> {
    finish(Mcm::from_start(setup, start)?)
}

fn finish(mut mcm: Mcm) -> Result<McmResult> {
    run(&mut mcm, &mut NoHooks)?;
    Ok(mcm.into_result())
}
