//! Running a DEM system to rest: the engine steps in checks of `check_every_s` simulated
//! seconds; after each check the stop rule decides (the bed at rest, or the time limit), an
//! overlap above a tenth of a diameter stops the run with an error, and the caller's hooks
//! ([`crate::driver::Hooks`]) see the check (progress, checkpoints, stop requests). Scenes,
//! validation runners and benchmarks run a bed to rest through [`run_to_rest`] or [`settle`].

use super::engine::{Dem, WallLedger};
use super::observe;
use crate::driver::{Hooks, NoHooks};
use crate::error::{invalid, require_positive};
use crate::Result;

/// Largest overlap (over the smaller diameter of the pair) a check accepts: beyond it the
/// contacts are too soft for the load and the run stops with an error.
pub const MAX_OVERLAP_RATIO: f64 = 0.1;

/// When a bed is at rest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Rest {
    /// The kinetic energy that settling can remove ([`Dem::settling_kinetic_energy`]) below
    /// `ke_fraction` of its peak over the checks, and the bed top moved less than
    /// `height_tol_over_d` mean diameters (of the start) since the previous check.
    PeakFraction {
        ke_fraction: f64,
        height_tol_over_d: f64,
    },
    /// The kinetic energy ([`Dem::kinetic_energy`]) below `below_j` (J) once the simulated time
    /// exceeds `after_s` (s).
    Absolute { below_j: f64, after_s: f64 },
}

/// Force balance, the second half of "at rest": the walls' mean force over each check
/// against the load they carry at rest ([`Dem::rest_load_n`]), |F_walls - L| / max(|F|, |L|,
/// F_floor) (under a pressure wall: floor against top, over the floor's force)
/// (for a bed under gravity alone, the floor force F against the buoyant weight W: |F/W - 1|
/// to first order), below `tol` at every check of the last `window_s` seconds. A mean over a
/// check is the momentum change over it divided by its length, so a bed that still bounces
/// on its contacts (the floor force swinging about W) fails it even at a kinetic-energy minimum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Balance {
    pub tol: f64,
    pub window_s: f64,
}

impl Balance {
    /// The default: within 1 % over 0.1 s (longer than the ~0.09 s bounce period of the
    /// built-in 400 um beds).
    pub const DEFAULT: Balance = Balance {
        tol: 0.01,
        window_s: 0.1,
    };
}

/// The stop rule: checks every `check_every_s` of simulated time, until the bed is at rest
/// (the rest rule and the force balance) or the time reaches `max_time_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StopRule {
    check_every_s: f64,
    max_time_s: f64,
    rest: Rest,
    balance: Balance,
}

/// `v` when positive and finite, else an error naming `name` and the value.
fn positive(name: &str, v: f64) -> Result<f64> {
    require_positive(v, || format!("{name} = {v}"))
}

impl StopRule {
    /// A rule with a positive check interval and time limit and positive thresholds (a
    /// non-negative start time of an absolute rule), and the default force balance
    /// ([`Balance::DEFAULT`]); errors name the value by its field.
    pub fn new(check_every_s: f64, max_time_s: f64, rest: Rest) -> Result<StopRule> {
        positive("check_every_s", check_every_s)?;
        positive("max_time_s", max_time_s)?;
        match rest {
            Rest::PeakFraction {
                ke_fraction,
                height_tol_over_d,
            } => {
                positive("ke_fraction", ke_fraction)?;
                positive("height_tol_over_d", height_tol_over_d)?;
            }
            Rest::Absolute { below_j, after_s } => {
                positive("below_j", below_j)?;
                if !(after_s.is_finite() && after_s >= 0.0) {
                    return invalid(format!("after_s = {after_s}: must be >= 0 and finite"));
                }
            }
        }
        Ok(StopRule {
            check_every_s,
            max_time_s,
            rest,
            balance: Balance::DEFAULT,
        })
    }

    /// The same rule with the force balance `balance` (positive tolerance, window >= 0 s; a
    /// window shorter than a check asks for the balance at the stopping check only).
    pub fn with_balance(self, balance: Balance) -> Result<StopRule> {
        positive("balance_tol", balance.tol)?;
        if !(balance.window_s.is_finite() && balance.window_s >= 0.0) {
            return invalid(format!(
                "balance_window_s = {}: must be >= 0 and finite",
                balance.window_s
            ));
        }
        Ok(StopRule { balance, ..self })
    }

    pub fn balance(&self) -> Balance {
        self.balance
    }

    /// Checks in a row the balance must hold for (at least 1).
    fn balance_checks(&self) -> u64 {
        ((self.balance.window_s / self.check_every_s).round() as u64).max(1)
    }

    pub fn check_every_s(&self) -> f64 {
        self.check_every_s
    }

    pub fn max_time_s(&self) -> f64 {
        self.max_time_s
    }

    pub fn rest(&self) -> Rest {
        self.rest
    }

    /// The same rule with the time limit `max_time_s` (s, positive).
    pub fn with_max_time_s(self, max_time_s: f64) -> Result<StopRule> {
        StopRule::new(self.check_every_s, max_time_s, self.rest)?.with_balance(self.balance)
    }
}

/// What the stop rule remembers between checks (a checkpoint keeps it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    /// Largest settling kinetic energy seen at a check (J).
    pub ke_peak_j: f64,
    /// Bed top at the previous check (m).
    pub top_prev_m: f64,
    /// Checks done since the start.
    pub checks: u64,
    /// Checks in a row, up to the last, whose force balance held.
    pub balanced_checks: u64,
    /// The last check's force imbalance |F_walls - L| / max(|F|, |L|, F_floor) (see [`Balance`]).
    pub imbalance: f64,
    /// The last check's mean z force of the floor on the particles (N).
    pub floor_force_mean_n: f64,
}

/// Highest sphere top of the bed (m).
fn bed_top(dem: &Dem) -> f64 {
    let z: Vec<f64> = dem.p.pos.iter().map(|p| p.z).collect();
    observe::bed_top(&z, &dem.p.radius)
}

impl Progress {
    /// Nothing seen yet, the bed top where it stands.
    pub fn start(dem: &Dem) -> Progress {
        Progress {
            ke_peak_j: 0.0,
            top_prev_m: bed_top(dem),
            checks: 0,
            balanced_checks: 0,
            imbalance: f64::INFINITY,
            floor_force_mean_n: 0.0,
        }
    }
}

/// The walls' mean force over a check (their impulse in `ledger` over `duration_s`) against
/// the load `load_n` they carry at rest: (imbalance, mean floor z force in N). Nothing to carry
/// and nothing carried is in balance.
fn wall_balance(
    ledger: &WallLedger,
    duration_s: f64,
    load_n: nalgebra::Vector3<f64>,
) -> (f64, f64) {
    let mean = ledger.impulse_ns / duration_s;
    // the scale of the forces the walls carry: under a pressure wall the floor and the top
    // wall each carry the wall's force while their sum (and the load) is near zero
    let floor_mean = (ledger.floor_impulse_ns / duration_s).abs();
    let scale = (ledger.magnitude_ns / duration_s)
        .max(load_n.norm())
        .max(floor_mean);
    let imbalance = if scale > 0.0 {
        (mean - load_n).norm() / scale
    } else {
        0.0
    };
    (imbalance, ledger.floor_impulse_ns / duration_s)
}

/// Why a run stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// The bed is at rest.
    AtRest,
    /// The time limit came first.
    TimeLimit,
}

impl Stop {
    /// The stop in words (a scene's summary prints it).
    pub fn reason(&self, rule: &StopRule) -> String {
        let Balance { tol, window_s } = rule.balance;
        let balance = format!("walls carry the load within {tol} over {window_s} s");
        match (self, rule.rest) {
            (Stop::AtRest, Rest::PeakFraction { ke_fraction, .. }) => {
                format!("settled: KE < {ke_fraction} of its peak, bed top steady, {balance}")
            }
            (Stop::AtRest, Rest::Absolute { below_j, after_s }) => {
                format!("settled: KE < {below_j} J after t = {after_s} s, {balance}")
            }
            (Stop::TimeLimit, _) => {
                format!("time limit {} s reached before settling", rule.max_time_s)
            }
        }
    }
}

/// What the hooks see after a check.
pub struct Check<'a> {
    pub dem: &'a Dem,
    /// The stop rule's memory, updated by the check.
    pub progress: &'a Progress,
    /// Kinetic energy at the check (J).
    pub kinetic_energy_j: f64,
    /// Largest overlap over the smaller diameter of its pair at the check.
    pub max_overlap_ratio: f64,
}

/// Steps `dem` check by check from `progress` until `rule` stops it (returns the stop) or a
/// hook asks to stop (returns `None`, as an interrupted run). After each check `hooks` get
/// the progress (the fraction of the time limit and a status line) and the chance to write a
/// checkpoint; then the stop rule ends the run, or the hooks may.
pub fn run_to_rest<H>(
    dem: &mut Dem,
    rule: &StopRule,
    progress: &mut Progress,
    hooks: &mut H,
) -> Result<Option<Stop>>
where
    H: for<'a> Hooks<Check<'a>>,
{
    let steps_per_check = ((rule.check_every_s / dem.dt_s()).round() as u64).max(1);
    let d_mean = dem.setup().start.mean_diameter_m();
    let load_n = dem.rest_load_n();
    loop {
        // the walls' impulse over the check gives their mean force (the caller's ledger, if
        // any, is put back with the check's impulse added)
        let outer = dem.wall_ledger.replace(WallLedger::default());
        let t0 = dem.time_s;
        let ran = dem.run(steps_per_check);
        let ledger = std::mem::replace(&mut dem.wall_ledger, outer).unwrap_or_default();
        ran?;
        if let Some(o) = &mut dem.wall_ledger {
            o.impulse_ns += ledger.impulse_ns;
            o.magnitude_ns += ledger.magnitude_ns;
            o.floor_impulse_ns += ledger.floor_impulse_ns;
        }
        (progress.imbalance, progress.floor_force_mean_n) =
            wall_balance(&ledger, dem.time_s - t0, load_n);
        progress.balanced_checks = if progress.imbalance < rule.balance.tol {
            progress.balanced_checks + 1
        } else {
            0
        };
        progress.checks += 1;
        let ke = dem.kinetic_energy();
        // the peak rule's energy leaves out the free spin of spheres touching nothing
        let ke_settling = dem.settling_kinetic_energy();
        progress.ke_peak_j = progress.ke_peak_j.max(ke_settling);
        let top = bed_top(dem);
        let ratio = dem.max_overlap_ratio();
        let too_deep = ratio > MAX_OVERLAP_RATIO;
        let stop = if too_deep {
            None
        } else {
            let at_rest = match rule.rest {
                Rest::PeakFraction {
                    ke_fraction,
                    height_tol_over_d,
                } => {
                    progress.ke_peak_j > 0.0
                        && ke_settling < ke_fraction * progress.ke_peak_j
                        && (top - progress.top_prev_m).abs() < height_tol_over_d * d_mean
                }
                Rest::Absolute { below_j, after_s } => dem.time_s > after_s && ke < below_j,
            } && progress.balanced_checks >= rule.balance_checks();
            progress.top_prev_m = top;
            if at_rest {
                Some(Stop::AtRest)
            } else if dem.time_s >= rule.max_time_s {
                Some(Stop::TimeLimit)
            } else {
                None
            }
        };
        let check = Check {
            dem,
            progress,
            kinetic_energy_j: ke,
            max_overlap_ratio: ratio,
        };
        let status = format!(
            "step {} t = {:.4} s KE = {ke:.2e} J overlap/d = {ratio:.2e} imbalance = {:.2e}",
            dem.steps, dem.time_s, progress.imbalance
        );
        hooks.progress(&check, Some(dem.time_s / rule.max_time_s), &status);
        hooks.checkpoint(&check)?;
        if too_deep {
            return invalid(format!(
                "overlap {ratio:.3} of a diameter at t = {:e} s: the contacts are too soft for the \
                 load (raise the Young's modulus, contact.young_pa, or lower the driving force)",
                dem.time_s
            ));
        }
        if stop.is_some() {
            return Ok(stop);
        }
        if hooks.stop_requested(&check) {
            return Ok(None);
        }
    }
}

/// Runs `dem` to rest by `rule` from where it stands, with no hooks.
pub fn settle(dem: &mut Dem, rule: &StopRule) -> Result<Stop> {
    let mut progress = Progress::start(dem);
    match run_to_rest(dem, rule, &mut progress, &mut NoHooks)? {
        Some(stop) => Ok(stop),
        None => invalid("DEM run stopped on request (no hooks were given to ask for it)"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::setup::testing::small_bed;

    #[test]
    fn stop_rule_refuses_bad_values_by_name() {
        let rest = Rest::PeakFraction {
            ke_fraction: 1e-6,
            height_tol_over_d: 1e-3,
        };
        let e = StopRule::new(0.0, 1.0, rest).unwrap_err().to_string();
        assert!(e.contains("check_every_s = 0"), "{e}");
        let bad = Rest::PeakFraction {
            ke_fraction: f64::NAN,
            height_tol_over_d: 1e-3,
        };
        let e = StopRule::new(0.01, 1.0, bad).unwrap_err().to_string();
        assert!(e.contains("ke_fraction = NaN"), "{e}");
        let rule = StopRule::new(0.01, 1.0, rest).unwrap();
        let e = rule
            .with_balance(Balance {
                tol: 0.0,
                window_s: 0.1,
            })
            .unwrap_err()
            .to_string();
        assert!(e.contains("balance_tol = 0"), "{e}");
        let e = rule
            .with_balance(Balance {
                tol: 0.01,
                window_s: -1.0,
            })
            .unwrap_err()
            .to_string();
        assert!(e.contains("balance_window_s = -1"), "{e}");
    }

    /// At rest means force balance: after the stop the floor's force, averaged step by step
    /// over a further 0.05 s, is the buoyant weight N m g (closed form) within the rule's 1 %,
    /// and the stop came only after the balance held over the whole window.
    #[test]
    fn a_bed_at_rest_carries_its_weight() {
        let rest = Rest::PeakFraction {
            ke_fraction: 1e-4,
            height_tol_over_d: 1e-2,
        };
        let rule = StopRule::new(0.01, 2.0, rest).unwrap();
        let mut dem = Dem::new(small_bed(60, 0.75)).unwrap();
        let mut progress = Progress::start(&dem);
        let stop = run_to_rest(&mut dem, &rule, &mut progress, &mut NoHooks).unwrap();
        assert_eq!(stop, Some(Stop::AtRest), "t = {}", dem.time_s);
        assert!(progress.balanced_checks >= 10 && progress.imbalance < 0.01);
        let s = dem.setup();
        let w: f64 = dem.p.mass.iter().sum::<f64>() * s.gravity_m_s2.norm();
        assert!(s.fluid_density_kg_m3 == 0.0 && (dem.buoyant_weight_n() - w).abs() < 1e-12 * w);
        let steps = (0.05 / dem.dt_s()).round() as u64;
        let mut sum = 0.0;
        for _ in 0..steps {
            dem.step().unwrap();
            sum += dem.floor_force_n;
        }
        let ratio = sum / steps as f64 / w;
        assert!((ratio - 1.0).abs() < 0.01, "floor force / weight {ratio}");
    }

    /// A small bed under gravity comes to rest by the peak rule before its time limit; the
    /// hooks see every check in order and a stop request interrupts the run there.
    #[test]
    fn a_settling_bed_comes_to_rest_and_hooks_see_every_check() {
        struct Count(u64, Option<u64>);
        impl<'a> Hooks<Check<'a>> for Count {
            fn progress(&mut self, c: &Check<'a>, done: Option<f64>, _: &str) {
                self.0 += 1;
                assert_eq!(c.progress.checks, self.0);
                assert!(done.is_some_and(|d| d > 0.0));
            }
            fn stop_requested(&mut self, _: &Check<'a>) -> bool {
                self.1.is_some_and(|m| self.0 >= m)
            }
        }
        let rest = Rest::PeakFraction {
            ke_fraction: 1e-4,
            height_tol_over_d: 1e-2,
        };
        let rule = StopRule::new(0.01, 1.0, rest).unwrap();
        let mut dem = Dem::new(small_bed(60, 0.75)).unwrap();
        let mut progress = Progress::start(&dem);
        let mut hooks = Count(0, Some(3));
        let stop = run_to_rest(&mut dem, &rule, &mut progress, &mut hooks).unwrap();
        assert_eq!((stop, hooks.0, progress.checks), (None, 3, 3));
        let mut hooks = Count(3, None);
        let stop = run_to_rest(&mut dem, &rule, &mut progress, &mut hooks).unwrap();
        assert_eq!(stop, Some(Stop::AtRest), "t = {}", dem.time_s);
        assert!(dem.time_s < 1.0 && hooks.0 == progress.checks);
        // a rule whose limit has passed stops at its next check
        let rule = rule.with_max_time_s(dem.time_s).unwrap();
        let absolute = StopRule::new(
            0.01,
            dem.time_s,
            Rest::Absolute {
                below_j: f64::MIN_POSITIVE,
                after_s: 0.0,
            },
        )
        .unwrap();
        assert_eq!(settle(&mut dem, &absolute).unwrap(), Stop::TimeLimit);
        assert!(Stop::TimeLimit.reason(&rule).starts_with("time limit"));
    }
}
