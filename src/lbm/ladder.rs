//! The permeability of a packing as an answer with its error: a ladder of resolutions, each
//! rung run until its k has settled to a fraction of the tolerance asked for, and k
//! extrapolated to infinite resolution by Richardson's rule from each pair of rungs. The
//! ladder climbs until two successive extrapolations agree within the tolerance.
//!
//! Why a rung stops on k itself: the driver's usual rule (the relative change of the mean
//! velocity per check below 1e-7) waits for the slowest mode of the flow. On a coarse lattice
//! that is the pressure equilibration of pockets joined to the pore space by one-cell throats
//! (a compressible fluid in a volume behind a narrow link: a slow relaxation), which hardly
//! moves k: on the 1000-sphere built-in packing at 16 cells (1.7 per diameter) k moved 0.12 %
//! between 20,900 and 56,400 steps, where the 32-cell lattice had settled in 9,500. Here the
//! rung projects the remaining change of k from its last three checks (Aitken's
//! extrapolation of a geometric approach) and stops when it is below [`STEADY_SHARE`] of the
//! ladder's tolerance.
//!
//! The extrapolation: k(n) = k_inf + c n^-2 (halfway bounce-back on a voxelised packing
//! converges at second order on average), fitted by least squares to the last three rungs
//! (Richardson's rule with one degree of freedom left to see the scatter). The staircase walls
//! make k scatter about that curve by up to about 1 % from one resolution to the next (the
//! voxels of each sphere change with n; on the 1000-sphere built-in packing at 54 cells k sat
//! 1.1 % below the curve through 32, 48, 64 and 96, each settled to 1e-7), which the
//! extrapolation from two rungs amplifies by (r^2 + 1) / (r^2 - 1) = 2.6 at r = 1.5; the fit
//! over three does not. The answer's error is the larger of the fit's standard error and its
//! change from the previous window; the ladder stops when both are below the tolerance. The
//! order observed on the last three rungs is reported beside.

use super::driver::SteadyControl;
use super::engine::Lbm;
use super::pore::{darcy_linearity, pore_permeability, PoreOptions, PoreResult};
use super::solver::superficial_mean;
use super::voxels::{voxelise, Voxels};
use crate::driver::Hooks;
use crate::error::{invalid, Result};
use crate::io::xyz::{Cell, XyzParticle};
use std::time::Instant;

/// The order of convergence the extrapolation assumes.
pub const ORDER: f64 = 2.0;

/// Ratio of successive rungs' resolutions.
pub const RATIO: f64 = 1.5;

/// A rung stops when the projected remaining change of its k is below this share of the
/// ladder's tolerance (the extrapolation from two rungs weighs their errors by up to
/// (r^2 + 1) / (r^2 - 1) = 2.6 at r = 1.5).
pub const STEADY_SHARE: f64 = 0.05;

/// What the ladder is asked for.
#[derive(Debug, Clone, Copy)]
pub struct LadderOptions {
    pub pore: PoreOptions,
    /// Cells along x of the first rung.
    pub start: usize,
    /// The finest rung allowed (cells along x).
    pub max_resolution: usize,
    /// Stop when two successive extrapolations differ by less than this (relative).
    pub rtol: f64,
}

/// One rung of the ladder.
#[derive(Debug, Clone)]
pub struct Rung {
    pub cells: usize,
    /// Cell edge in the configuration's length unit.
    pub dx: f64,
    pub result: PoreResult,
    /// Wall-clock seconds of the rung's flow.
    pub seconds: f64,
    /// Whether the rung's k settled (the projection or the driver's residual rule).
    pub settled: bool,
    /// k_inf fitted to this rung and the two before (None on the first two), and its
    /// standard error.
    pub k_extrapolated: Option<(f64, f64)>,
}

/// A rung's own run, as a [`RungStore`] keeps it (what follows from the rungs before it, the
/// extrapolation, is recomputed).
#[derive(Debug, Clone)]
pub struct RungRun {
    pub result: PoreResult,
    pub settled: bool,
    /// Wall-clock seconds of the rung's flow.
    pub seconds: f64,
    /// Darcy's law on the second rung (NaN on the others).
    pub darcy_change: f64,
}

/// What a ladder keeps between processes (`porelab permeability --out` keeps it in the
/// folder's checkpoint), and the hooks of the running rung's steady run, which may restore it
/// from a checkpoint. A ladder climbed through a store holding a killed ladder's rungs ends as
/// the uninterrupted one would.
pub trait RungStore: Hooks<Lbm> {
    /// The rung at `n` cells, if an earlier process finished it.
    fn finished(&mut self, n: usize) -> Result<Option<RungRun>>;
    /// The store becomes the hooks of the rung at `n` cells; returns the mean velocities along
    /// x at the checks up to the state its `restore` loads (empty for a fresh start).
    fn start(&mut self, n: usize) -> Vec<f64>;
    /// The running rung ended.
    fn ended(&mut self, run: &RungRun) -> Result<()>;
}

/// The ladder's answer.
#[derive(Debug)]
pub struct Ladder {
    pub rungs: Vec<Rung>,
    /// The last extrapolation, and its estimated error: the larger of the fit's standard
    /// error and its change from the window before.
    pub k: f64,
    pub k_error: f64,
    /// The order observed on the last three rungs (None with fewer, or without a monotone
    /// sequence).
    pub observed_order: Option<f64>,
    pub converged: bool,
    /// Darcy's law on the second rung: k at half the force relative to k, minus 1.
    pub darcy_change: f64,
    /// The finest rung's voxels (for its fields' output).
    pub finest: Voxels,
}

/// The rungs' resolutions: `start`, then each 1.5 times the one before (rounded), up to
/// `max_resolution`.
pub fn rung_resolutions(start: usize, max_resolution: usize) -> Vec<usize> {
    let mut out = vec![start];
    loop {
        let last = out[out.len() - 1];
        let next = ((last as f64) * RATIO).round() as usize;
        if next > max_resolution || next <= last {
            return out;
        }
        out.push(next);
    }
}

/// k_inf and its standard error from the least-squares fit of k = k_inf + c n^-p to three or
/// more rungs (`n` cells, `k`). None for fewer than three rungs.
pub fn fitted_limit(n: &[usize], k: &[f64], p: f64) -> Option<(f64, f64)> {
    let m = n.len();
    if m < 3 || k.len() != m {
        return None;
    }
    let x: Vec<f64> = n.iter().map(|&c| (c as f64).powf(-p)).collect();
    let mean = |v: &[f64]| v.iter().sum::<f64>() / m as f64;
    let (xm, km) = (mean(&x), mean(k));
    let sxx: f64 = x.iter().map(|xi| (xi - xm).powi(2)).sum();
    let sxk: f64 = x.iter().zip(k).map(|(xi, ki)| (xi - xm) * (ki - km)).sum();
    let slope = sxk / sxx;
    let limit = km - slope * xm;
    let rss: f64 = x
        .iter()
        .zip(k)
        .map(|(xi, ki)| (ki - limit - slope * xi).powi(2))
        .sum();
    // Var(k_inf) = s^2 (1/m + xm^2 / sxx), s^2 = RSS / (m - 2)
    let se = (rss / (m - 2) as f64 * (1.0 / m as f64 + xm * xm / sxx)).sqrt();
    Some((limit, se))
}

/// The order p for which three rungs' k lie on k_inf + c n^-p (bisection on p in [0.25, 8]);
/// None when the differences change sign or no p in the range fits.
pub fn observed_order(n: [usize; 3], k: [f64; 3]) -> Option<f64> {
    let (d1, d2) = (k[0] - k[1], k[1] - k[2]);
    if d1 == 0.0 || d2 == 0.0 || d1.signum() != d2.signum() {
        return None;
    }
    let target = d1 / d2;
    let h = n.map(|c| 1.0 / c as f64);
    // (h1^p - h2^p) / (h2^p - h3^p) increases with p for h1 > h2 > h3
    let ratio = |p: f64| (h[0].powf(p) - h[1].powf(p)) / (h[1].powf(p) - h[2].powf(p));
    let (mut lo, mut hi) = (0.25, 8.0);
    if !(ratio(lo) <= target && target <= ratio(hi)) {
        return None;
    }
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if ratio(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// The remaining change of a sequence approaching its limit geometrically, projected from its
/// last three values (Aitken): d2 q / (1 - q) with q = d2 / d1. None while the sequence is not
/// in a monotone geometric approach (q outside [0, 1)).
pub fn projected_change(last: [f64; 3]) -> Option<f64> {
    let (d1, d2) = (last[1] - last[0], last[2] - last[1]);
    if d2 == 0.0 {
        return Some(0.0);
    }
    if d1 == 0.0 {
        return None;
    }
    let q = d2 / d1;
    (0.0..1.0).contains(&q).then(|| d2 * q / (1.0 - q))
}

/// Hooks that stop a steady run once the projected remaining change of the mean velocity
/// along x (k is proportional to it) is below `tol` of its value, passing progress on.
///
/// The rule is judged where the driver offers a checkpoint, before passing it on: a check at
/// which k settles writes no checkpoint, so a run resumed from the last one it wrote judges
/// that check again rather than stepping past it (a checkpoint written at the settling check
/// would resume one check later than the uninterrupted run stops).
struct SettledK<'a> {
    inner: &'a mut dyn Hooks<Lbm>,
    last: Vec<f64>,
    tol: f64,
    settled: bool,
}

impl SettledK<'_> {
    /// Adds the check's mean velocity along x to `last` and judges the rule on the last three.
    fn judge(&mut self, lbm: &Lbm) {
        // the check's mean over two steps (driver::fields_over_two_steps), kept on the engine
        let u = match &lbm.monitor {
            Some(m) => m.mean_u[0],
            None => superficial_mean(&lbm.fields())[0],
        };
        self.last.push(u);
        let n = self.last.len();
        if n >= 3 {
            let last = [self.last[n - 3], self.last[n - 2], self.last[n - 1]];
            if let Some(rest) = projected_change(last) {
                let moved = (last[2] - last[1]).abs();
                if rest.abs() < self.tol * u.abs() && moved < self.tol * u.abs() {
                    self.settled = true;
                }
            }
        }
    }
}

impl Hooks<Lbm> for SettledK<'_> {
    fn progress(&mut self, lbm: &Lbm, done: Option<f64>, status: &str) {
        self.inner.progress(lbm, done, status);
    }

    fn checkpoint(&mut self, lbm: &Lbm) -> Result<()> {
        self.judge(lbm);
        if self.settled {
            return Ok(());
        }
        self.inner.checkpoint(lbm)
    }

    fn restore(&mut self, lbm: &mut Lbm) -> Result<()> {
        self.inner.restore(lbm)
    }

    fn stop_requested(&mut self, lbm: &Lbm) -> bool {
        self.settled || self.inner.stop_requested(lbm)
    }
}

/// Permeability of `v` with the run stopped once k has settled to `tol` (relative), `last`
/// the mean velocities along x at the checks before the state `hooks` restore; returns the
/// result and whether it settled (by the projection, or by the driver's own residual).
fn settled_permeability(
    v: &Voxels,
    o: &PoreOptions,
    tol: f64,
    hooks: &mut dyn Hooks<Lbm>,
    last: Vec<f64>,
) -> Result<(PoreResult, bool)> {
    let mut stop = SettledK {
        inner: hooks,
        last,
        tol,
        settled: false,
    };
    let r = pore_permeability(v, o, &mut stop)?;
    let settled = stop.settled || r.run.converged;
    Ok((r, settled))
}

/// Climbs the ladder on the configuration (`cell`, `particles`); `store` gives the rungs an
/// earlier process finished and is the hooks of the others, and `on_rung` sees each rung as it
/// ends.
pub fn climb(
    cell: &Cell,
    particles: &[XyzParticle],
    o: &LadderOptions,
    store: &mut impl RungStore,
    mut on_rung: impl FnMut(&Rung),
) -> Result<Ladder> {
    if !(o.rtol.is_finite() && o.rtol > 0.0 && o.rtol < 1.0) {
        return invalid(format!("--rtol = {}: must lie in (0, 1)", o.rtol));
    }
    let plan = rung_resolutions(o.start, o.max_resolution);
    if plan.len() < 4 {
        return invalid(format!(
            "resolutions {} to {}: the ladder needs four rungs ({:?}); raise \
             --max-resolution or lower the start",
            o.start, o.max_resolution, plan
        ));
    }
    let mut rungs: Vec<Rung> = Vec::new();
    let mut darcy_change = f64::NAN;
    let mut finest = None;
    let mut converged = false;
    for &n in &plan {
        let v = voxelise(cell, particles, n)?;
        let run = match store.finished(n)? {
            Some(kept) => kept,
            None => {
                let t = Instant::now();
                let last = store.start(n);
                let tol = STEADY_SHARE * o.rtol;
                let (result, settled) = settled_permeability(&v, &o.pore, tol, store, last)?;
                let seconds = t.elapsed().as_secs_f64();
                let darcy_change = match rungs.len() {
                    1 => darcy_linearity_settled(&v, &o.pore, result.k, tol)?,
                    _ => f64::NAN,
                };
                let run = RungRun {
                    result,
                    settled,
                    seconds,
                    darcy_change,
                };
                store.ended(&run)?;
                run
            }
        };
        if rungs.len() == 1 {
            darcy_change = run.darcy_change;
        }
        let RungRun {
            result,
            settled,
            seconds,
            ..
        } = run;
        let mut cells: Vec<usize> = rungs.iter().map(|r| r.cells).collect();
        let mut ks: Vec<f64> = rungs.iter().map(|r| r.result.k).collect();
        cells.push(n);
        ks.push(result.k);
        let from = cells.len().saturating_sub(3);
        let k_extrapolated = fitted_limit(&cells[from..], &ks[from..], ORDER);
        let rung = Rung {
            cells: n,
            dx: v.dx,
            result,
            seconds,
            settled,
            k_extrapolated,
        };
        on_rung(&rung);
        rungs.push(rung);
        finest = Some(v);
        let m = rungs.len();
        if m >= 4 {
            if let (Some((a, _)), Some((b, se))) =
                (rungs[m - 2].k_extrapolated, rungs[m - 1].k_extrapolated)
            {
                if ((b - a) / b).abs() < o.rtol && se < o.rtol * b.abs() {
                    converged = true;
                    break;
                }
            }
        }
    }
    let m = rungs.len();
    let (Some((a, _)), Some((b, se))) = (rungs[m - 2].k_extrapolated, rungs[m - 1].k_extrapolated)
    else {
        return invalid("the ladder ended before two extrapolations");
    };
    let observed = observed_order(
        [rungs[m - 3].cells, rungs[m - 2].cells, rungs[m - 1].cells],
        [
            rungs[m - 3].result.k,
            rungs[m - 2].result.k,
            rungs[m - 1].result.k,
        ],
    );
    let Some(finest) = finest else {
        return invalid("the ladder ran no rung");
    };
    Ok(Ladder {
        k: b,
        k_error: (b - a).abs().max(se),
        observed_order: observed,
        converged,
        darcy_change,
        finest,
        rungs,
    })
}

/// [`darcy_linearity`] with both runs settled to `tol` on k.
fn darcy_linearity_settled(v: &Voxels, o: &PoreOptions, k: f64, tol: f64) -> Result<f64> {
    let mut stop = SettledK {
        inner: &mut crate::driver::NoHooks,
        last: Vec::new(),
        tol,
        settled: false,
    };
    darcy_linearity(v, o, k, &mut stop)
}

/// The steady control of a rung: the projection stops it, the driver's residual rule only
/// past any useful precision, and `max_steps` bounds it.
pub fn rung_control(max_steps: u64) -> SteadyControl {
    SteadyControl {
        check_every: 100,
        tol: 1e-12,
        max_steps,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Saves the engine's state at every checkpoint it is offered, with the checks before it.
    #[derive(Default)]
    struct SaveEach {
        saved: Vec<(String, usize)>,
        checks: usize,
        restore: Option<String>,
    }

    impl Hooks<Lbm> for SaveEach {
        fn checkpoint(&mut self, lbm: &Lbm) -> Result<()> {
            self.checks += 1;
            let state = serde_json::to_string(&lbm.save_state().unwrap()).unwrap();
            self.saved.push((state, self.checks));
            Ok(())
        }
        fn restore(&mut self, lbm: &mut Lbm) -> Result<()> {
            match self.restore.take() {
                Some(t) => lbm.load_state(&serde_json::from_str(&t).unwrap()),
                None => Ok(()),
            }
        }
    }

    /// A rung resumed from any checkpoint it wrote (a kill just after the write) ends on the
    /// step and the k bits of the uninterrupted rung, the last checkpoint included: the check
    /// at which k settles writes none, or the resumed rung would run one check further.
    #[test]
    fn a_rung_resumed_from_any_checkpoint_ends_as_the_whole_rung() {
        use crate::lbm::{CollisionKind, CollisionModel, LatticeKind, Tau};
        let ball = XyzParticle::sphere(nalgebra::Vector3::from([0.5; 3]), 0.31);
        let v = voxelise(&Cell::cubic(1.0), &[ball], 12).unwrap();
        let trt = CollisionModel::new(CollisionKind::Trt, Tau::new(1.0).unwrap());
        let o = PoreOptions::new(
            LatticeKind::D3Q19,
            trt,
            (1e-6, "force"),
            rung_control(50_000),
        )
        .unwrap();
        let tol = STEADY_SHARE * 1e-6;
        let mut record = SaveEach::default();
        let (whole, settled) = settled_permeability(&v, &o, tol, &mut record, Vec::new()).unwrap();
        assert!(settled && !whole.run.converged && record.saved.len() >= 3);
        let us: Vec<f64> = {
            let mut again = SaveEach::default();
            let mut stop = SettledK {
                inner: &mut again,
                last: Vec::new(),
                tol,
                settled: false,
            };
            pore_permeability(&v, &o, &mut stop).unwrap();
            stop.last
        };
        for (state, checks) in std::mem::take(&mut record.saved) {
            let mut resume = SaveEach {
                restore: Some(state),
                ..SaveEach::default()
            };
            let last = us[..checks].to_vec();
            let (r, settled) = settled_permeability(&v, &o, tol, &mut resume, last).unwrap();
            assert!(settled, "resumed after check {checks}");
            assert_eq!(
                (r.run.steps, r.k.to_bits()),
                (whole.run.steps, whole.k.to_bits()),
                "resumed after check {checks}"
            );
        }
    }

    /// k(n) = k_inf + c n^-2 is recovered exactly from any two rungs, and its order from three;
    /// a sequence with another order gives that order.
    #[test]
    fn richardson_and_the_observed_order_on_closed_forms() {
        let k = |n: usize, p: f64| 0.654e-3 + 0.2 * (n as f64).powf(-p);
        let (e, se) =
            fitted_limit(&[24, 36, 54], &[k(24, 2.0), k(36, 2.0), k(54, 2.0)], 2.0).unwrap();
        assert!((e / 0.654e-3 - 1.0).abs() < 1e-10 && se < 1e-12, "{e} {se}");
        // scatter about the curve shows in the standard error: +-1 % on the middle rung of
        // three (n = 24, 36, 54) moves k_inf by the fit's weight and gives s.e. > 0
        let (e, se) = fitted_limit(
            &[24, 36, 54],
            &[k(24, 2.0), 1.01 * k(36, 2.0), k(54, 2.0)],
            2.0,
        )
        .unwrap();
        assert!(se > 0.0 && (e / 0.654e-3 - 1.0).abs() < 0.05, "{e} {se}");
        assert!(fitted_limit(&[24, 36], &[1.0, 0.9], 2.0).is_none());
        let p = observed_order([16, 24, 36], [k(16, 2.0), k(24, 2.0), k(36, 2.0)]).unwrap();
        assert!((p - 2.0).abs() < 1e-9, "{p}");
        let p = observed_order([16, 24, 36], [k(16, 1.3), k(24, 1.3), k(36, 1.3)]).unwrap();
        assert!((p - 1.3).abs() < 1e-9, "{p}");
        // not monotone: no order
        assert!(observed_order([16, 24, 36], [1.0, 0.9, 0.95]).is_none());
    }

    /// Aitken's projection is exact on a geometric sequence and declines a non-geometric one.
    #[test]
    fn projected_change_of_a_geometric_approach() {
        let s = |i: i32| 2.0 - 0.5 * 0.8f64.powi(i);
        let rest = projected_change([s(3), s(4), s(5)]).unwrap();
        // exact but for rounding: differences of values near 2 carry ~50 ulps of 2
        assert!((rest - (2.0 - s(5))).abs() < 1e-13, "{rest}");
        assert!(projected_change([1.0, 2.0, 1.5]).is_none());
        assert!(projected_change([1.0, 2.0, 4.0]).is_none());
        assert_eq!(projected_change([1.0, 1.0, 1.0]), Some(0.0));
    }

    #[test]
    fn rungs_grow_by_half() {
        assert_eq!(rung_resolutions(16, 128), vec![16, 24, 36, 54, 81, 122]);
        assert_eq!(rung_resolutions(16, 20), vec![16]);
    }
}
