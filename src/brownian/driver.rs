//! Running a Brownian-dynamics simulation: a number of steps, or a number of steps sampled at
//! intervals, with the caller's progress and stop hooks ([`Hooks`]) after every step; and an
//! ensemble of independent runs in parallel.

use super::Simulation;
use crate::driver::Hooks;
use crate::Result;

/// `steps` steps of `sim`. After each, the progress hook hears the fraction of the `steps`
/// done (no status line: a step can take a microsecond, and the hook reads the simulation);
/// the run stops early when the stop hook asks (Ok: a stop is not an error).
pub fn run_steps(
    sim: &mut Simulation,
    steps: u64,
    hooks: &mut impl Hooks<Simulation>,
) -> Result<()> {
    for k in 1..=steps {
        sim.step()?;
        hooks.progress(sim, Some(k as f64 / steps as f64), "");
        if hooks.stop_requested(sim) {
            break;
        }
    }
    Ok(())
}

/// `steps` steps of `sim`, with `sample(sim)` after every `every` steps and after the last one
/// (the last interval may be shorter); the hooks as in [`run_steps`], with the fraction of each
/// interval. An error of `sample` stops the run.
pub fn run_sampled(
    sim: &mut Simulation,
    steps: u64,
    every: u64,
    hooks: &mut impl Hooks<Simulation>,
    mut sample: impl FnMut(&Simulation) -> Result<()>,
) -> Result<()> {
    let every = every.max(1);
    let mut done = 0;
    while done < steps {
        let k = every.min(steps - done);
        run_steps(sim, k, hooks)?;
        done += k;
        sample(sim)?;
        if hooks.stop_requested(sim) {
            break;
        }
    }
    Ok(())
}
/// Runs `runs` independent runs (0..runs) on `threads` worker threads (None: all cores).
/// The results, in run order, depend only on `seed`, not on the thread count.
pub fn run_ensemble<T: Send>(
    runs: u64,
    threads: Option<usize>,
    one: impl Fn(u64) -> Result<T> + Sync + Send,
) -> Result<Vec<T>> {
    use rayon::prelude::*;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| crate::Error::InvalidInput(format!("thread pool: {e}")))?;
    pool.install(|| (0..runs).into_par_iter().map(one).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brownian::{run_rng, Fluid, Particles, Setup};
    use crate::driver::NoHooks;
    use nalgebra::Vector3;

    /// 10 steps sampled every 3: samples after 3, 6, 9 and 10 steps; the same positions as
    /// 10 single steps of the same stream; a stop request ends the run after that step.
    #[test]
    fn sampling_intervals_and_stops() {
        let sim = || {
            let p = Particles::new(vec![Vector3::zeros()], 1e-7).unwrap();
            let setup = Setup::new(p, Fluid::new(298.0, 1e-3).unwrap(), 1e-6).unwrap();
            Simulation::new(setup, run_rng(3, 1)).unwrap()
        };
        let mut a = sim();
        let mut at = Vec::new();
        run_sampled(&mut a, 10, 3, &mut NoHooks, |s| {
            at.push((s.time_s() / 1e-6).round() as u64);
            Ok(())
        })
        .unwrap();
        assert_eq!(at, [3, 6, 9, 10]);
        let mut b = sim();
        for _ in 0..10 {
            b.step().unwrap();
        }
        assert_eq!(a.particles(), b.particles());
        struct StopAt(u64);
        impl Hooks<Simulation> for StopAt {
            fn stop_requested(&mut self, s: &Simulation) -> bool {
                (s.time_s() / 1e-6).round() as u64 >= self.0
            }
        }
        let mut c = sim();
        run_steps(&mut c, 100, &mut StopAt(4)).unwrap();
        assert_eq!((c.time_s() / 1e-6).round(), 4.0);
    }
}
