//! The deposition loop (seed 000, Fig. 1): [`Deposition::step`] is one sweep of one trial move
//! per particle, in index order; the driver (`driver.rs`) sweeps until the mean displacement
//! per sweep falls below `stop.fraction` of the first sweep's.
//!
//! The drainage speed V of a sweep is the mean displacement of the previous sweep (rejected
//! moves count 0) divided by the time unit (a scene parameter; V = 0 in the first sweep).
//! The mean displacement is that of the centres, |dr| averaged over all N trials. The stop
//! rule compares the mean over the last `stop.window` sweeps (default 10) with the first
//! sweep's: with a few hundred particles and a few per cent accepted, a single sweep can move
//! nothing by chance while the layer is still settling, and the seed's rule read on one sweep
//! would stop there. Two rest rules may replace it: `stop.supported` stops when a given
//! fraction of the spheres is supported by its contacts (support.rs), read every `stop.window`
//! sweeps; `stop.accepted_rate` stops when the accepted moves per particle per sweep, averaged
//! over the window, fall below a threshold (at T = 0 a deposit at rest accepts no move).

use super::cells::{wrap_xy, Cells};
use super::energy::accept;
use super::grain::GrainPose;
use super::moves;
use super::overlap::PrefilterCounts;
use super::setup::{Moves, Setup, StopRule};
use super::{film, support, Layer};
use crate::error::{invalid, Result};
use nalgebra::Vector3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

/// One sweep's record.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SweepRecord {
    pub sweep: u64,
    /// Mean centre displacement per trial, m.
    pub mean_displacement_m: f64,
    /// Accepted fraction of the sweep's trials.
    pub acceptance: f64,
    /// Drainage speed V used in this sweep, m/s.
    pub drainage_speed_m_s: f64,
}

/// What a run did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DepositionOutcome {
    pub sweeps: u64,
    pub moves: u64,
    pub accepted: u64,
    /// The stop rule was met (false: `max_sweeps` reached).
    pub converged: bool,
    /// Mean displacement of the first sweep that moved a particle, m (the stop rule's
    /// reference).
    pub first_displacement_m: f64,
    pub prefilters: PrefilterCounts,
    pub history: Vec<SweepRecord>,
}

/// A deposit in progress: the layer, how its grains move, when it stops, its random stream,
/// and what the sweeps so far did.
pub struct Deposition {
    pub(super) layer: Layer,
    pub(super) moves: Moves,
    pub(super) stop: StopRule,
    pub(super) rng: ChaCha8Rng,
    pub(super) cells: Cells,
    pub(super) positions: Vec<Vector3<f64>>,
    /// Drainage speed V of the next sweep, m/s.
    pub(super) v: f64,
    /// Sum of the mean displacements of the last `stop.window` sweeps, m.
    pub(super) window_sum: f64,
    /// Their mean after the last sweep, m.
    pub(super) recent_m: f64,
    /// Sum of the accepted fractions of the last `stop.window` sweeps.
    pub(super) window_accepted: f64,
    /// Their mean after the last sweep: accepted moves per particle per sweep.
    pub(super) recent_acceptance: f64,
    /// The first sweep that moved a particle (0: none yet): the stop rule's reference.
    pub(super) reference_sweep: u64,
    pub(super) outcome: DepositionOutcome,
}

impl Deposition {
    /// Run `run` of `setup`: the grains (sizes drawn) and the start of the film built from the
    /// run's random stream ([`Setup::run_rng`]), which the moves then continue.
    pub fn new(setup: &Setup, run: usize) -> Result<Deposition> {
        setup.check()?;
        let mut rng = setup.run_rng(run);
        let grains = setup.grains(&mut rng)?;
        let phi = setup.pigment_volume_fraction()?;
        let layer = film::build(grains, setup.box_side_m, phi, &setup.start, &mut rng)?;
        Deposition::from_layer(layer, setup.moves, setup.stop, rng)
    }

    /// The deposit of a given `layer`, its moves drawn from `rng` (continued as it is).
    pub fn from_layer(
        layer: Layer,
        moves: Moves,
        stop: StopRule,
        rng: ChaCha8Rng,
    ) -> Result<Deposition> {
        moves.check()?;
        stop.check()?;
        if layer.grains.is_empty() {
            return invalid("the layer holds no particles");
        }
        if stop.supported.is_some() && layer.grains.iter().any(|g| !g.is_sphere) {
            return invalid(
                "stop_supported_fraction: the at-rest stop rule reads the support of spheres; \
                 this deposit holds non-spherical particles",
            );
        }
        if moves.energy.gravity {
            if let Some((i, g)) = layer
                .grains
                .iter()
                .enumerate()
                .find(|(_, g)| g.buoyant_weight_n.is_nan() || g.buoyant_weight_n <= 0.0)
            {
                return invalid(format!(
                    "particle {i} (species {}) is not heavier than the fluid (buoyant weight {} \
                     N): it would never settle",
                    g.species, g.buoyant_weight_n
                ));
            }
        } else if !moves.energy.drag {
            return invalid("neither gravity nor drag is on: no move can lower the energy");
        }
        let cells = layer.cells();
        let positions = layer.poses.iter().map(|p| p.position).collect();
        Ok(Deposition {
            layer,
            moves,
            stop,
            rng,
            cells,
            positions,
            v: 0.0,
            window_sum: 0.0,
            recent_m: 0.0,
            window_accepted: 0.0,
            recent_acceptance: 0.0,
            reference_sweep: 0,
            outcome: DepositionOutcome {
                sweeps: 0,
                moves: 0,
                accepted: 0,
                converged: false,
                first_displacement_m: 0.0,
                prefilters: PrefilterCounts::default(),
                history: Vec::new(),
            },
        })
    }

    /// The layer as it is now.
    pub fn layer(&self) -> &Layer {
        &self.layer
    }

    /// What the sweeps so far did.
    pub fn outcome(&self) -> &DepositionOutcome {
        &self.outcome
    }

    /// The mean displacement per sweep over the stop rule's window after the last sweep, m.
    pub fn recent_displacement_m(&self) -> f64 {
        self.recent_m
    }

    /// The accepted moves per particle per sweep over the stop rule's window after the last
    /// sweep.
    pub fn recent_acceptance(&self) -> f64 {
        self.recent_acceptance
    }

    /// The stop value: `stop.fraction` times the first sweep's mean displacement, m.
    pub fn stop_displacement_m(&self) -> f64 {
        self.stop.fraction * self.outcome.first_displacement_m
    }

    /// True when the stop rule was met or `max_sweeps` sweeps are done.
    pub fn is_done(&self) -> bool {
        self.outcome.converged || self.outcome.sweeps >= self.stop.max_sweeps
    }

    /// The final layer and the record of the run.
    pub fn into_parts(self) -> (Layer, DepositionOutcome) {
        (self.layer, self.outcome)
    }

    /// One sweep: a trial move of every particle in index order, accepted iff it lowers the
    /// energy (eq. A2, A11; Metropolis at T > 0) and creates no overlap. No move in the whole
    /// first stop window is an error (the start is jammed).
    pub fn step(&mut self) -> Result<SweepRecord> {
        if self.is_done() {
            return invalid(format!(
                "the deposit stopped after {} sweeps: no further sweep",
                self.outcome.sweeps
            ));
        }
        let layer = &mut self.layer;
        let (params, rng, v) = (&self.moves, &mut self.rng, self.v);
        let out = &mut self.outcome;
        let n = layer.grains.len();
        let sweep = out.sweeps + 1;
        let mut displacement = 0.0f64;
        let mut accepted = 0u64;
        for j in 0..n {
            let g = layer.grains[j];
            let mut m = moves::draw(rng, params.k_max_m2, &g.inertia_per_volume_m2);
            if params.isotropic_directions {
                m = moves::isotropic(rng, m);
            }
            let old = layer.poses[j];
            let t = Vector3::from(m.translation_m);
            let mut trial = GrainPose {
                position: old.position + t,
                orientation: if g.is_sphere {
                    old.orientation
                } else {
                    m.rotate(&old.orientation)
                },
            };
            let (c_old, c_new) = if g.is_sphere || !params.energy.drag {
                (g.drag_m[0], g.drag_m[0])
            } else {
                (g.drag_zz(&old.orientation), g.drag_zz(&trial.orientation))
            };
            let de = params
                .energy
                .delta(g.buoyant_weight_n, t.z, old.position.z, c_old, c_new, v);
            if !accept(de, params.kt_j, || rng.gen::<f64>()) {
                continue;
            }
            wrap_xy(&mut trial.position, layer.box_side_m);
            if !layer.fits(
                &self.cells,
                &self.positions,
                j,
                &trial,
                1.0,
                None,
                None,
                &mut out.prefilters,
            ) {
                continue;
            }
            layer.poses[j] = trial;
            self.positions[j] = trial.position;
            self.cells.moved(j, &trial.position);
            accepted += 1;
            displacement += t.norm();
        }
        let mean = displacement / n as f64;
        out.sweeps = sweep;
        out.moves += n as u64;
        out.accepted += accepted;
        let record = SweepRecord {
            sweep,
            mean_displacement_m: mean,
            acceptance: accepted as f64 / n as f64,
            drainage_speed_m_s: v,
        };
        out.history.push(record);
        // The reference is the first sweep that moves a particle: with a few particles a
        // first sweep can move none by chance (a free sphere at T = 0 accepts about half of its
        // trials). No move over the whole first window is an error (the start is jammed).
        if self.reference_sweep == 0 {
            if mean > 0.0 {
                self.reference_sweep = sweep;
                out.first_displacement_m = mean;
            } else if sweep >= self.stop.window {
                return invalid(format!(
                    "no particle could move in the first {sweep} sweeps (the stop window): the \
                     start is jammed or no energy term can be lowered"
                ));
            }
        }
        let stop = self.stop.fraction * out.first_displacement_m;
        // Running sums over the window (exact re-summation every 4096 sweeps against drift).
        let window = self.stop.window;
        self.window_sum += mean;
        self.window_accepted += record.acceptance;
        if sweep > window {
            let old = &out.history[(sweep - window - 1) as usize];
            self.window_sum -= old.mean_displacement_m;
            self.window_accepted -= old.acceptance;
        }
        let w = window.min(sweep) as usize;
        if sweep.is_multiple_of(4096) {
            let last = &out.history[out.history.len() - w..];
            self.window_sum = last.iter().map(|h| h.mean_displacement_m).sum::<f64>();
            self.window_accepted = last.iter().map(|h| h.acceptance).sum::<f64>();
        }
        self.recent_m = self.window_sum / w as f64;
        self.recent_acceptance = self.window_accepted / w as f64;
        // the window holds only sweeps from the reference on
        let window_full = self.reference_sweep > 0
            && (sweep + 1).saturating_sub(self.reference_sweep) >= window.max(2);
        let at_rest = match (self.stop.supported, self.stop.accepted_rate) {
            // the at-rest rule: the supported fraction, read every window sweeps
            (Some(target), _) => {
                sweep.is_multiple_of(window)
                    && support::supported_fraction(&self.layer).is_some_and(|s| s >= target)
            }
            // the accepted-move rest rule
            (None, Some(rate)) => window_full && self.recent_acceptance < rate,
            // the seed's displacement rule
            (None, None) => window_full && self.recent_m < stop,
        };
        if at_rest {
            out.converged = true;
        } else {
            self.v = mean / self.moves.time_unit_s;
        }
        Ok(record)
    }
}

#[cfg(test)]
mod tests {
    use super::super::grain::Grain;
    use super::*;
    use nalgebra::UnitQuaternion;
    use rand::SeedableRng;

    /// The ridge of a square column (case 606): a sphere resting on two periodic images of the
    /// sphere below, side L = 1.2 d, 0.02 d from the top of the ridge towards the hollow.
    /// Downhill moves exist (along the ridge), and the overlap test accepts exactly the
    /// enumerated trials that an all-images distance check accepts: the slow descent is not a
    /// rejected valid move. The seed's directions (eq. A16: components as the square roots of
    /// uniform shares) rarely point along a coordinate axis, and this ridge runs along y, so
    /// they find its downhill moves far less often than isotropic directions of the same
    /// lengths do.
    #[test]
    fn a_sphere_on_an_axis_aligned_ridge_has_downhill_moves_the_seed_rule_rarely_draws() {
        let (r, d): (f64, f64) = (0.5e-6, 1e-6);
        let l = 1.2 * d;
        let g = Grain::new([r; 3], 0, 2500.0, 1000.0, 9.8).unwrap();
        let y = 0.02 * d;
        let z = r + (d * d - 0.25 * l * l - y * y).sqrt() * (1.0 + 1e-12);
        let pose = |x: f64, y: f64, z: f64| GrainPose {
            position: Vector3::new(x, y, z),
            orientation: UnitQuaternion::identity(),
        };
        let layer = Layer {
            grains: vec![g; 2],
            poses: vec![pose(0.0, 0.0, r), pose(0.5 * l, y, z)],
            box_side_m: l,
            film_height_m: z,
        };
        let cells = layer.cells();
        let positions: Vec<_> = layer.poses.iter().map(|p| p.position).collect();
        let mut counts = PrefilterCounts::default();
        let mut fits = |t: Vector3<f64>| {
            let mut trial = layer.poses[1];
            trial.position += t;
            wrap_xy(&mut trial.position, l);
            layer.fits(&cells, &positions, 1, &trial, 1.0, None, None, &mut counts)
        };
        // independent: every image of the lower sphere within two periods, and the substrate
        let clear = |t: Vector3<f64>| {
            let p = layer.poses[1].position + t;
            p.z >= r
                && (-2..=2).all(|sx| {
                    (-2..=2).all(|sy| {
                        let c = Vector3::new(sx as f64 * l, sy as f64 * l, r);
                        (p - c).norm() >= d
                    })
                })
        };
        // directions on a Fibonacci sphere, three step lengths up to the largest translation
        let n = 20_000;
        let mut downhill = 0;
        for k in 0..n {
            let cz = 1.0 - (2.0 * k as f64 + 1.0) / n as f64;
            let phi = k as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
            let s = (1.0 - cz * cz).sqrt();
            let dir = Vector3::new(s * phi.cos(), s * phi.sin(), cz);
            for len in [1e-9, 1e-8, 5e-8] {
                let t = dir * len;
                let ok = fits(t);
                assert_eq!(ok, clear(t), "direction {k}, step {len} m");
                downhill += usize::from(ok && t.z < 0.0);
            }
        }
        assert!(downhill > 0);
        // accepted downhill trials: eq. A16 draws against isotropic ones of the same length
        let mut rng = ChaCha8Rng::seed_from_u64(606);
        let (mut seed_rule, mut isotropic) = (0u32, 0u32);
        for _ in 0..200_000 {
            let m = moves::draw(&mut rng, 1e-14, &g.inertia_per_volume_m2);
            let t = Vector3::from(m.translation_m);
            seed_rule += u32::from(t.z < 0.0 && fits(t));
            let t = Vector3::from(moves::isotropic(&mut rng, m).translation_m);
            isotropic += u32::from(t.z < 0.0 && fits(t));
        }
        assert!(isotropic >= 20, "isotropic {isotropic}");
        assert!(
            10 * seed_rule <= isotropic,
            "eq. A16 {seed_rule}, isotropic {isotropic}"
        );
    }
}
