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
