//! Driving a solver to its steady state: the residual is the relative change of the
//! superficial mean velocity over `check_every` steps; the run stops below `tol`, and refuses
//! a flow whose Mach number grows past the stability limit, whose fields are not finite, or
//! whose velocity is too small for double-precision populations to resolve.

use super::solver::{superficial_mean, Fields, Solver};
use super::units::MACH_MAX;
use super::{Collision, Forcing, Lattice};
use crate::error::{invalid, Result};

/// When to stop.
#[derive(Debug, Clone, Copy)]
pub struct SteadyControl {
    pub check_every: u64,
    /// Stop when |<u>_n - <u>_{n-1}| / |<u>_n| < tol.
    pub tol: f64,
    pub max_steps: u64,
}

/// What a steady run reached.
#[derive(Debug, Clone)]
pub struct Steady {
    pub fields: Fields,
    pub mean_u: [f64; 3],
    pub residual: f64,
    pub steps: u64,
    pub converged: bool,
    /// Largest |u| (lattice units).
    pub u_max: f64,
}

/// The smallest largest-velocity (lattice units) a steady run reports: about 5e5 ulps of the
/// populations (order 1). Measured on a Guo-Zhao channel whose velocity scales with the
/// porosity: u_max 6e-13 came out 1 % off the Brinkman solution, 6e-14 12 %, 4e-18 100 %, each
/// with a residual of exactly 0 (increments lost to rounding).
pub const U_RESOLVED: f64 = 1e-10;

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Runs `s` until steady (or `max_steps`); `progress(steps, residual)` is called after each check.
pub fn run_steady<L: Lattice, C: Collision, F: Forcing>(
    s: &mut Solver<L, C, F>,
    ctl: SteadyControl,
    mut progress: impl FnMut(u64, f64),
) -> Result<Steady> {
    if ctl.check_every == 0 || ctl.tol.is_nan() || ctl.tol <= 0.0 {
        return invalid(format!(
            "steady control: check_every = {} must be >= 1 and tol = {} > 0",
            ctl.check_every, ctl.tol
        ));
    }
    let mut prev = superficial_mean(&s.fields());
    let start = s.steps();
    loop {
        s.run(ctl.check_every);
        let fields = s.fields();
        let mean = superficial_mean(&fields);
        let mut u_max: f64 = 0.0;
        for u in &fields.u {
            let n = norm(*u);
            if !n.is_finite() {
                return invalid(format!(
                    "the flow became non-finite after {} steps: the lattice parameters are unstable",
                    s.steps()
                ));
            }
            u_max = u_max.max(n);
        }
        let mach = u_max * 3f64.sqrt();
        if mach > MACH_MAX {
            return invalid(format!(
                "Mach number {mach:.3} (u_max = {u_max:.3e} lattice units) after {} steps exceeds \
                 {MACH_MAX}: lower the driving force or refine the lattice",
                s.steps()
            ));
        }
        let m = norm(mean);
        let residual = if m > 0.0 {
            norm([mean[0] - prev[0], mean[1] - prev[1], mean[2] - prev[2]]) / m
        } else {
            0.0
        };
        progress(s.steps(), residual);
        prev = mean;
        let converged = residual < ctl.tol;
        if converged || s.steps() - start >= ctl.max_steps {
            if u_max < U_RESOLVED {
                return invalid(format!(
                    "the flow's largest velocity after {} steps is {u_max:.3e} (lattice units), \
                     below {U_RESOLVED:.0e}: populations of order 1 in double precision do not \
                     resolve it, and a residual of {residual:.2e} means nothing (the per-step \
                     increments are lost to rounding); drive the flow harder, or check the \
                     porosity and permeability (a porosity near 0 stops a Guo-Zhao flow)",
                    s.steps()
                ));
            }
            return Ok(Steady {
                fields,
                mean_u: mean,
                residual,
                steps: s.steps(),
                converged,
                u_max,
            });
        }
    }
}

/// The progress display of a steady run, on stderr: a bar that fills as the residual falls
/// from its first value to the stop value (on a log scale, never moving back), with the step
/// count, the residual and the stop value. Hidden when `quiet` (indicatif also hides it when
/// stderr is not a terminal). Pass `|s, r| p.update(s, r)` as the progress of [`run_steady`].
pub struct SteadyProgress {
    bar: indicatif::ProgressBar,
    tol: f64,
    first: Option<f64>,
}

/// Positions of the bar between the first residual and the stop value.
const BAR_LEN: u64 = 1000;

impl SteadyProgress {
    pub fn new(tol: f64, quiet: bool) -> SteadyProgress {
        let bar = if quiet {
            indicatif::ProgressBar::hidden()
        } else {
            let b = indicatif::ProgressBar::new(BAR_LEN);
            b.set_style(
                indicatif::ProgressStyle::with_template("[{elapsed_precise}] {bar:30} {msg}")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b
        };
        SteadyProgress {
            bar,
            tol,
            first: None,
        }
    }

    /// Shows the check after `steps` steps that gave `residual`.
    pub fn update(&mut self, steps: u64, residual: f64) {
        let tol = self.tol;
        self.bar.set_message(format!(
            "step {steps}: residual {residual:.2e} (stop below {tol:.1e})"
        ));
        if residual > 0.0 && residual.is_finite() {
            let first = *self.first.get_or_insert(residual.max(tol));
            let span = (first / tol).ln();
            let frac = if span > 0.0 {
                ((first / residual).ln() / span).clamp(0.0, 1.0)
            } else {
                1.0
            };
            let pos = (frac * BAR_LEN as f64).round() as u64;
            if pos > self.bar.position() {
                self.bar.set_position(pos);
            }
        } else if residual == 0.0 {
            self.bar.set_position(BAR_LEN);
        }
    }

    /// Removes the display.
    pub fn finish(self) {
        self.bar.finish_and_clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bar is empty at the first residual, half full at the geometric mean of it and the
    /// stop value, full at the stop value, and never moves back when the residual rises.
    #[test]
    fn progress_fills_on_a_log_scale_towards_the_stop_value() {
        let mut p = SteadyProgress::new(1e-8, true);
        p.update(100, 1e-2);
        assert_eq!(p.bar.position(), 0);
        p.update(200, 1e-5);
        assert_eq!(p.bar.position(), BAR_LEN / 2);
        p.update(300, 1e-3);
        assert_eq!(p.bar.position(), BAR_LEN / 2);
        assert!(p
            .bar
            .message()
            .contains("residual 1.00e-3 (stop below 1.0e-8)"));
        p.update(400, 1e-9);
        assert_eq!(p.bar.position(), BAR_LEN);
        p.finish();
    }
}
