//! Running a deposit to its end: sweeps until the stop rule is met or `max_sweeps` sweeps are
//! done, with the caller's progress and stop hooks ([`Hooks`]) after every sweep; and run k of
//! an ensemble, from its start to its end.

use super::engine::{Deposition, DepositionOutcome};
use super::setup::{Moves, Setup, StopRule};
use super::Layer;
use crate::driver::Hooks;
use crate::Result;
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

/// Sweeps `d` until it is done (or the hooks ask to stop). After each sweep the progress hook
/// hears the sweep, the mean displacement over the stop rule's window and the stop value, and
/// the checkpoint hook may save the state.
pub fn run(d: &mut Deposition, hooks: &mut impl Hooks<Deposition>) -> Result<()> {
    while !d.is_done() {
        let r = d.step()?;
        hooks.progress(
            d,
            None,
            &format!(
                "sweep {}, mean displacement {:.3e} m, stop below {:.3e} m",
                r.sweep,
                d.recent_displacement_m(),
                d.stop_displacement_m()
            ),
        );
        hooks.checkpoint(d)?;
        if hooks.stop_requested(d) {
            break;
        }
    }
    Ok(())
}

/// One finished run of an ensemble.
pub struct Deposited {
    pub run: usize,
    pub layer: Layer,
    pub outcome: DepositionOutcome,
    /// Wall time of building the start, s.
    pub start_seconds: f64,
}

/// Run `k` of `setup`: its start ([`Deposition::new`]) and its deposit to the end.
pub fn run_one(setup: &Setup, k: usize, hooks: &mut impl Hooks<Deposition>) -> Result<Deposited> {
    let t0 = Instant::now();
    let mut d = Deposition::new(setup, k)?;
    let start_seconds = t0.elapsed().as_secs_f64();
    run(&mut d, hooks)?;
    let (layer, outcome) = d.into_parts();
    Ok(Deposited {
        run: k,
        layer,
        outcome,
        start_seconds,
    })
}

/// Deposits a given `layer` with `moves` until `stop`, drawing from `rng` (continued as it
/// is): the final layer and the record of the run.
pub fn run_layer(
    layer: Layer,
    moves: Moves,
    stop: StopRule,
    rng: ChaCha8Rng,
    hooks: &mut impl Hooks<Deposition>,
) -> Result<(Layer, DepositionOutcome)> {
    let mut d = Deposition::from_layer(layer, moves, stop, rng)?;
    run(&mut d, hooks)?;
    Ok(d.into_parts())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deposition::grain::{Grain, GrainPose};
    use crate::driver::NoHooks;
    use nalgebra::{UnitQuaternion, Vector3};
    use rand::SeedableRng;

    /// One sphere high above the substrate: the run ends at `max_sweeps` without converging
    /// (a window as long as the run), after exactly that many sweeps, and a further sweep is
    /// refused.
    #[test]
    fn a_run_ends_at_max_sweeps_and_refuses_more() {
        let r = 0.5e-6;
        let g = Grain::new([r; 3], 0, 2500.0, 1000.0, 9.8).unwrap();
        let pose = GrainPose {
            position: Vector3::new(5.0 * r, 5.0 * r, 100.0 * r),
            orientation: UnitQuaternion::identity(),
        };
        let layer = Layer {
            grains: vec![g],
            poses: vec![pose],
            box_side_m: 10.0 * r,
            film_height_m: 100.0 * r,
        };
        let stop = StopRule {
            fraction: 1e-300,
            window: 50,
            max_sweeps: 50,
            supported: None,
            accepted_rate: None,
        };
        let rng = ChaCha8Rng::seed_from_u64(1);
        let mut d = Deposition::from_layer(layer, Moves::table_b1(), stop, rng).unwrap();
        run(&mut d, &mut NoHooks).unwrap();
        assert_eq!(d.outcome().sweeps, 50);
        assert!(!d.outcome().converged && d.is_done());
        assert!(d.layer().poses[0].position.z < 100.0 * r);
        assert!(d.step().is_err());
    }

    /// One free sphere: at T = 0 a sweep of one trial moves it only when the trial goes down
    /// (half the time), so some streams move nothing in the first sweep. The run goes on, and
    /// the stop reference is the first sweep that moved; a start where nothing moves in the
    /// whole first window (a sphere lying on the substrate) is refused.
    #[test]
    fn a_first_sweep_that_moves_nothing_is_not_the_reference() {
        let r = 0.5e-6;
        let g = Grain::new([r; 3], 0, 2500.0, 1000.0, 9.8).unwrap();
        let layer_at = |z: f64| Layer {
            grains: vec![g],
            poses: vec![GrainPose {
                position: Vector3::new(5.0 * r, 5.0 * r, z),
                orientation: UnitQuaternion::identity(),
            }],
            box_side_m: 10.0 * r,
            film_height_m: z,
        };
        let stop = StopRule {
            fraction: 1e-300,
            window: 5,
            max_sweeps: 40,
            supported: None,
            accepted_rate: None,
        };
        let mut idle_first = 0;
        for seed in 0..16 {
            let rng = ChaCha8Rng::seed_from_u64(seed);
            let (_, out) = run_layer(
                layer_at(100.0 * r),
                Moves::table_b1(),
                stop,
                rng,
                &mut NoHooks,
            )
            .unwrap();
            let first_moving = out
                .history
                .iter()
                .find(|h| h.mean_displacement_m > 0.0)
                .unwrap();
            assert_eq!(out.first_displacement_m, first_moving.mean_displacement_m);
            if out.history[0].mean_displacement_m == 0.0 {
                idle_first += 1;
                assert!(first_moving.sweep > 1 && out.first_displacement_m > 0.0);
            }
        }
        // the case the rule exists for occurred (about half the streams)
        assert!(idle_first >= 2, "{idle_first} of 16 first sweeps idle");
        let rng = ChaCha8Rng::seed_from_u64(1);
        let jammed = run_layer(layer_at(r), Moves::table_b1(), stop, rng, &mut NoHooks);
        assert!(jammed.is_err());
    }

    /// The accepted-move rest rule: spheres settling onto the substrate run until the accepted
    /// moves per particle per sweep, averaged over the window, fall below the threshold, and
    /// stop at the first sweep where the history says so (read again here from the sweeps'
    /// records); a free sphere (half its trials accepted) never meets it. The seed's
    /// displacement rule stays the default.
    #[test]
    fn the_accepted_move_rule_stops_at_the_first_quiet_window() {
        assert_eq!(StopRule::table_b1(10).accepted_rate, None);
        let r = 0.5e-6;
        let g = Grain::new([r; 3], 0, 2500.0, 1000.0, 9.8).unwrap();
        let l = 8.0 * r;
        let poses = (0..4)
            .map(|k| GrainPose {
                position: Vector3::new(
                    (1.0 + 4.0 * (k % 2) as f64) * r,
                    (1.0 + 4.0 * (k / 2) as f64) * r,
                    1.3 * r,
                ),
                orientation: UnitQuaternion::identity(),
            })
            .collect();
        let layer = Layer {
            grains: vec![g; 4],
            poses,
            box_side_m: l,
            film_height_m: 1.3 * r,
        };
        let (window, rate) = (20u64, 0.05);
        let stop = StopRule {
            fraction: 1e-300,
            window,
            max_sweeps: 100_000,
            supported: None,
            accepted_rate: Some(rate),
        };
        let rng = ChaCha8Rng::seed_from_u64(3);
        let (layer, out) =
            run_layer(layer.clone(), Moves::table_b1(), stop, rng, &mut NoHooks).unwrap();
        assert!(out.converged);
        let acc: Vec<f64> = out.history.iter().map(|h| h.acceptance).collect();
        let reference = out
            .history
            .iter()
            .position(|h| h.mean_displacement_m > 0.0)
            .unwrap();
        let quiet = |end: usize| {
            end + 1 >= reference + window as usize
                && acc[end + 1 - window as usize..=end].iter().sum::<f64>() / (window as f64) < rate
        };
        let first_quiet = (0..acc.len()).find(|&e| quiet(e)).unwrap();
        assert_eq!(first_quiet + 1, out.sweeps as usize);
        // it ran long enough to settle: every sphere within 0.05 r of the substrate (acceptance 0.2 there, 4 times the threshold)
        assert!(out.sweeps > window && layer.poses.iter().all(|p| p.position.z - r < 0.05 * r));
        // a free sphere: about half its trials accepted, so no window of 200 is quiet (fewer than
        // 40 of 200 accepted: 8.5 standard deviations below the mean)
        let free = Layer {
            grains: vec![g],
            poses: vec![GrainPose {
                position: Vector3::new(r, r, 1e3 * r),
                orientation: UnitQuaternion::identity(),
            }],
            box_side_m: l,
            film_height_m: 1e3 * r,
        };
        let stop = StopRule {
            window: 200,
            max_sweeps: 2000,
            accepted_rate: Some(0.2),
            ..stop
        };
        let rng = ChaCha8Rng::seed_from_u64(4);
        let (_, out) = run_layer(free, Moves::table_b1(), stop, rng, &mut NoHooks).unwrap();
        assert!(!out.converged && out.sweeps == 2000);
        // both rest rules at once are refused
        let both = StopRule {
            supported: Some(0.9),
            ..stop
        };
        assert!(both.check().is_err());
    }
}
