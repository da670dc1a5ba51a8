//! Running a flow to its steady state: the residual is the relative change of the superficial
//! mean velocity over `check_every` steps; the run stops below `tol`, and refuses a flow whose
//! Mach number grows past the stability limit, whose fields are not finite, or whose velocity
//! is too small for double-precision populations to resolve. Progress, checkpoints and stop
//! requests go through [`crate::driver::Hooks`]; [`SteadyBar`] is the progress display.

use super::engine::{Lbm, Monitor};
use super::solver::{superficial_mean, Fields};
use super::units::MACH_MAX;
use crate::driver::Hooks;
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

/// Runs `lbm` until steady (or `max_steps`, or a stop request of `hooks`: then not converged).
/// First `hooks` may restore the engine from a checkpoint (the run then continues from the
/// saved check). After each check `hooks` gets the progress (the fraction of [`LogProgress`],
/// and the step and residual as text) and, unless the run ends there, may write a checkpoint.
pub fn run_steady(lbm: &mut Lbm, ctl: SteadyControl, hooks: &mut dyn Hooks<Lbm>) -> Result<Steady> {
    if ctl.check_every == 0 || ctl.tol.is_nan() || ctl.tol <= 0.0 {
        return invalid(format!(
            "steady control: check_every = {} must be >= 1 and tol = {} > 0",
            ctl.check_every, ctl.tol
        ));
    }
    hooks.restore(lbm)?;
    let mut done = LogProgress::new(ctl.tol);
    let (start, mut prev) = match lbm.resumed.take() {
        Some(m) => {
            done.first = m.first_residual;
            (m.start_steps, m.mean_u)
        }
        None => (lbm.steps(), superficial_mean(&lbm.fields())),
    };
    loop {
        let fields = fields_over_two_steps(lbm, ctl.check_every)?;
        let mean = superficial_mean(&fields);
        let mut u_max: f64 = 0.0;
        for u in &fields.u {
            let n = norm(*u);
            if !n.is_finite() {
                return invalid(format!(
                    "the flow became non-finite after {} steps: the lattice parameters are unstable",
                    lbm.steps()
                ));
            }
            u_max = u_max.max(n);
        }
        let mach = u_max * 3f64.sqrt();
        if mach > MACH_MAX {
            return invalid(format!(
                "Mach number {mach:.3} (u_max = {u_max:.3e} lattice units) after {} steps exceeds \
                 {MACH_MAX}: lower the driving force or refine the lattice",
                lbm.steps()
            ));
        }
        let m = norm(mean);
        let residual = if m > 0.0 {
            norm([mean[0] - prev[0], mean[1] - prev[1], mean[2] - prev[2]]) / m
        } else {
            0.0
        };
        let steps = lbm.steps();
        let status = format!(
            "step {steps}: residual {residual:.2e} (stop below {:.1e})",
            ctl.tol
        );
        hooks.progress(lbm, done.at(residual), &status);
        prev = mean;
        let converged = residual < ctl.tol;
        let ends = converged || steps - start >= ctl.max_steps;
        lbm.monitor = Some(Monitor {
            start_steps: start,
            mean_u: mean,
            first_residual: done.first,
        });
        if !ends {
            hooks.checkpoint(lbm)?;
        }
        if ends || hooks.stop_requested(lbm) {
            if u_max < U_RESOLVED {
                return invalid(format!(
                    "the flow's largest velocity after {steps} steps is {u_max:.3e} (lattice \
                     units), below {U_RESOLVED:.0e}: populations of order 1 in double precision \
                     do not resolve it, and a residual of {residual:.2e} means nothing (the \
                     per-step increments are lost to rounding); drive the flow harder, or check \
                     the porosity and permeability (a porosity near 0 stops a Guo-Zhao flow)"
                ));
            }
            return Ok(Steady {
                fields,
                mean_u: mean,
                residual,
                steps,
                converged,
                u_max,
            });
        }
    }
}

/// Runs `n` >= 1 steps and returns the density and velocity averaged over the last two.
///
/// Halfway bounce-back has modes of eigenvalue -1 that no collision damps: at a fluid node whose
/// links carrying momentum along some axis all end in solid at both ends (a node in a one-cell
/// gap; common in a packing voxelised at a few cells per diameter), collision conserves that
/// momentum and the two bounce-backs reverse it, so under a body force g it alternates between
/// g/2 and -g/2 after the Guo half-force term, for ever; where such links are only some of a
/// node's, the alternation decays at the rate 1 - 1/tau_minus per step (0.86 at TRT tau 1),
/// so slowly that a check every even number of steps sees a drift. One step's velocity then
/// carries an offset that does not scale with 1/nu, and k = nu <u> / g depends on tau at fixed
/// TRT Lambda, which it must not (I. Ginzburg, Commun. Comput. Phys. 3, 427 (2008)). Measured on
/// the built-in 1000-sphere packing at 12 cells across (D3Q19 TRT, Lambda 3/16, an independent
/// NumPy code): k at even steps 0.013227 / 0.013595 / 0.014822 at tau 0.7 / 1 / 2, the mean of
/// two consecutive steps 0.0129817850 at all three (9 digits); at 16 cells, tau 1, k at even
/// steps was still 7.8 % high and falling after 12,000 steps while the two-step mean had
/// settled to 1e-6 by 2,000. The mean over the period is the steady flow.
pub fn fields_over_two_steps(lbm: &mut Lbm, n: u64) -> Result<Fields> {
    lbm.run(n.saturating_sub(1))?;
    let a = lbm.fields();
    lbm.step()?;
    let b = lbm.fields();
    let rho = a
        .rho
        .iter()
        .zip(&b.rho)
        .map(|(x, y)| 0.5 * (x + y))
        .collect();
    let u =
        a.u.iter()
            .zip(&b.u)
            .map(|(x, y)| {
                [
                    0.5 * (x[0] + y[0]),
                    0.5 * (x[1] + y[1]),
                    0.5 * (x[2] + y[2]),
                ]
            })
            .collect();
    Ok(Fields { rho, u })
}

/// How far a steady run has come: the fall of the residual from its first value to the stop
/// value `tol`, on a log scale (0 at the first residual, 1/2 at their geometric mean, 1 at
/// `tol`).
pub struct LogProgress {
    tol: f64,
    first: Option<f64>,
}

impl LogProgress {
    pub fn new(tol: f64) -> LogProgress {
        LogProgress { tol, first: None }
    }

    /// The fraction at `residual` (None for a residual that is not a positive number or 0).
    pub fn at(&mut self, residual: f64) -> Option<f64> {
        let tol = self.tol;
        if residual > 0.0 && residual.is_finite() {
            let first = *self.first.get_or_insert(residual.max(tol));
            let span = (first / tol).ln();
            Some(if span > 0.0 {
                ((first / residual).ln() / span).clamp(0.0, 1.0)
            } else {
                1.0
            })
        } else if residual == 0.0 {
            Some(1.0)
        } else {
            None
        }
    }
}

/// The progress display of a steady run, on stderr: a bar that fills with the fraction the
/// driver reports (never moving back) and its status line (step, residual, stop value).
/// Hidden when `quiet` (indicatif also hides it when stderr is not a terminal); removed when
/// dropped. One bar per run.
pub struct SteadyBar {
    bar: indicatif::ProgressBar,
}

/// Positions of the bar.
const BAR_LEN: u64 = 1000;

impl SteadyBar {
    pub fn new(quiet: bool) -> SteadyBar {
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
        SteadyBar { bar }
    }
}

impl Hooks<Lbm> for SteadyBar {
    fn progress(&mut self, _lbm: &Lbm, done: Option<f64>, status: &str) {
        self.bar.set_message(status.to_string());
        if let Some(f) = done {
            let pos = (f * BAR_LEN as f64).round() as u64;
            if pos > self.bar.position() {
                self.bar.set_position(pos);
            }
        }
    }
}

impl Drop for SteadyBar {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fraction is 0 at the first residual, 1/2 at the geometric mean of it and the stop
    /// value, 1 at the stop value and beyond, 1 at a residual of exactly 0; a residual above the
    /// first gives 0, and the bar never moves back.
    #[test]
    fn progress_fills_on_a_log_scale_towards_the_stop_value() {
        let mut p = LogProgress::new(1e-8);
        assert_eq!(p.at(1e-2), Some(0.0));
        assert!((p.at(1e-5).unwrap() - 0.5).abs() < 1e-12);
        assert_eq!(p.at(1e-1), Some(0.0));
        assert_eq!(p.at(1e-9), Some(1.0));
        assert_eq!(p.at(0.0), Some(1.0));
        assert_eq!(p.at(f64::NAN), None);
        let mut b = SteadyBar::new(true);
        let shown = |b: &SteadyBar| b.bar.position();
        // the bar only needs an engine for its signature; it does not read it
        use crate::lbm::{CollisionKind, CollisionModel, Dims, Domain, LatticeKind, Setup, Tau};
        let coll = CollisionModel::new(CollisionKind::Bgk, Tau::new(1.0).unwrap());
        let one = Domain::open(Dims::new(1, 1, 1).unwrap());
        let lbm = Lbm::new(Setup::new(LatticeKind::D3Q15, coll, one)).unwrap();
        b.progress(
            &lbm,
            Some(0.5),
            "step 200: residual 1.00e-5 (stop below 1.0e-8)",
        );
        assert_eq!(shown(&b), BAR_LEN / 2);
        b.progress(&lbm, Some(0.25), "x");
        assert_eq!(shown(&b), BAR_LEN / 2);
        b.progress(&lbm, None, "y");
        assert_eq!(shown(&b), BAR_LEN / 2);
        assert_eq!(b.bar.message(), "y");
    }
}
