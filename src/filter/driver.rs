//! Runs a filter to its end: until every fed particle is captured or has passed, or a number
//! of steps is done, with progress, checkpoint and stop requests through [`Hooks`].

use super::Filter;
use crate::driver::Hooks;
use crate::Result;

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// No particle is left inside.
    Empty,
    /// `max_steps` steps were done with particles still inside.
    StepLimit,
    /// The hooks asked to stop.
    Requested,
}

/// Steps `f` until no particle is inside or `max_steps` steps (counted from t = 0) are done.
/// First `hooks` may restore `f` from a checkpoint (the run continues from the saved step).
/// After every step: `progress` (the fraction of the fed particles no longer inside), then
/// `checkpoint`, then `stop_requested`.
pub fn run_to_end(f: &mut Filter, max_steps: u64, hooks: &mut dyn Hooks<Filter>) -> Result<Stop> {
    hooks.restore(f)?;
    loop {
        let c = f.counts();
        if c.inside == 0 {
            return Ok(Stop::Empty);
        }
        if f.steps() >= max_steps {
            return Ok(Stop::StepLimit);
        }
        f.step()?;
        let c = f.counts();
        let status = format!(
            "t = {:.4e} s: {} captured, {} passed, {} inside",
            f.time_s(),
            c.captured,
            c.passed,
            c.inside
        );
        hooks.progress(f, Some(1.0 - c.inside as f64 / c.fed as f64), &status);
        hooks.checkpoint(f)?;
        if c.inside > 0 && hooks.stop_requested(f) {
            return Ok(Stop::Requested);
        }
    }
}
