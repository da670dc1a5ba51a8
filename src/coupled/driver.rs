//! Runs a coupled system to its end: to a number of coupling steps (a scene's simulated time),
//! with progress, output and stop requests through [`Hooks`], or to a steady state of an
//! observable of the flow.

use super::engine::Coupled;
use crate::driver::Hooks;
use crate::Result;

/// Coupling steps of dt_LBM that cover `time_s` from t = 0 (the last one may end past it).
pub fn steps_for(c: &Coupled, time_s: f64) -> u64 {
    (time_s / c.units.dt).ceil() as u64
}

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// The last coupling step was done.
    End,
    /// The hooks asked to stop before it.
    Requested,
}

/// Steps `c` from its current step until `end_step` coupling steps are done. After every step
/// the hooks see the system: `progress` (fraction of the steps done), then `checkpoint` (the
/// place to write outputs; its error ends the run), then `stop_requested`.
pub fn run_to_step(c: &mut Coupled, end_step: u64, hooks: &mut dyn Hooks<Coupled>) -> Result<Stop> {
    while c.steps < end_step {
        c.step()?;
        let status = format!("t = {:.4e} s, imbalance {:.1e}", c.time_s, c.worst_balance);
        hooks.progress(c, Some(c.steps as f64 / end_step as f64), &status);
        hooks.checkpoint(c)?;
        if c.steps < end_step && hooks.stop_requested(c) {
            return Ok(Stop::Requested);
        }
    }
    Ok(Stop::End)
}

/// The end of [`run_to_steady`]: the observable's last value, the coupling steps this call
/// took, and whether the last two values agreed to the tolerance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Steady {
    pub value: f64,
    pub steps: u64,
    pub steady: bool,
}

/// Steps `c` until `observe` changes by at most `rtol` of its value from one coupling step to
/// the next, or `max_steps` steps were taken.
pub fn run_to_steady(
    c: &mut Coupled,
    max_steps: u64,
    rtol: f64,
    mut observe: impl FnMut(&Coupled) -> f64,
) -> Result<Steady> {
    let (mut value, mut previous) = (f64::NAN, f64::INFINITY);
    for s in 1..=max_steps {
        c.step()?;
        value = observe(c);
        if (value - previous).abs() <= rtol * value.abs() {
            return Ok(Steady {
                value,
                steps: s,
                steady: true,
            });
        }
        previous = value;
    }
    Ok(Steady {
        value,
        steps: max_steps,
        steady: false,
    })
}
