//! The deposition loop (seed 000, Fig. 1): sweeps of one trial move per particle, in index
//! order, until the mean displacement per sweep falls below `stop_fraction` of the first
//! sweep's.
//!
//! The drainage speed V of a sweep is the mean displacement of the previous sweep (rejected
//! moves count 0) divided by the time unit (a scene parameter; V = 0 in the first sweep).
//! The mean displacement is that of the centres, |dr| averaged over all N trials. The stop
//! rule compares the mean over the last `stop_window` sweeps (default 10) with the first
//! sweep's: with a few hundred particles and a few per cent accepted, a single sweep can move
//! nothing by chance while the layer is still settling, and the seed's rule read on one sweep
//! would stop there.

use super::energy::{accept, EnergyTerms};
use super::grain::GrainPose;
use super::moves;
use super::overlap::PrefilterCounts;
use super::Layer;
use crate::error::{invalid, Result};
use nalgebra::Vector3;
use rand::Rng;
use serde::Serialize;

/// The parameters of a deposition run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepositionParams {
    /// Maximum kinetic-energy constraint K_max, m^2 (Table B1: 1e-14).
    pub k_max_m2: f64,
    pub energy: EnergyTerms,
    /// The time unit over which the previous sweep's mean displacement gives V, s.
    pub time_unit_s: f64,
    /// kT, J (0: the seed's T = 0).
    pub kt_j: f64,
    /// Stop when the mean displacement per sweep, averaged over the last `stop_window`
    /// sweeps, is below this fraction of the first sweep's.
    pub stop_fraction: f64,
    /// Sweeps averaged by the stop rule (1: the last sweep alone).
    pub stop_window: u64,
    /// Guard: stop after this many sweeps (reported as not converged).
    pub max_sweeps: u64,
}

impl DepositionParams {
    /// Table B1 (mu = 0.01 Pa s, K_max = 1e-14 m^2, T = 0), buoyant gravity and drag on, a
    /// time unit of 1 s, the stop rule at 1e-3 over 10 sweeps, `max_sweeps` as the guard.
    pub fn table_b1(max_sweeps: u64) -> DepositionParams {
        DepositionParams {
            k_max_m2: 1e-14,
            energy: EnergyTerms {
                gravity: true,
                drag: true,
                viscosity_pa_s: 0.01,
            },
            time_unit_s: 1.0,
            kt_j: 0.0,
            stop_fraction: 1e-3,
            stop_window: 10,
            max_sweeps,
        }
    }

    /// Checks every value, naming it.
    pub fn check(&self) -> Result<()> {
        let pos = |name: &str, v: f64| -> Result<()> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                invalid(format!("{name} = {v}: must be positive and finite"))
            }
        };
        pos("k_max_m2", self.k_max_m2)?;
        pos("time_unit_s", self.time_unit_s)?;
        if self.energy.drag {
            pos("viscosity_pa_s", self.energy.viscosity_pa_s)?;
        }
        if !(self.kt_j.is_finite() && self.kt_j >= 0.0) {
            return invalid(format!("kT = {} J: must be >= 0 and finite", self.kt_j));
        }
        if !(self.stop_fraction > 0.0 && self.stop_fraction < 1.0) {
            return invalid(format!(
                "stop_fraction = {}: must be in (0, 1)",
                self.stop_fraction
            ));
        }
        if self.stop_window == 0 || self.stop_window > 10_000_000 {
            return invalid(format!(
                "stop_window = {}: must be 1 to 10000000",
                self.stop_window
            ));
        }
        if self.max_sweeps == 0 {
            return invalid("max_sweeps = 0: must be at least 1");
        }
        Ok(())
    }
}

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
    /// Mean displacement of the first sweep, m (the stop rule's reference).
    pub first_displacement_m: f64,
    pub prefilters: PrefilterCounts,
    pub history: Vec<SweepRecord>,
}

/// Deposits `layer` in place. `progress(sweep, mean displacement, stop value)` is called after
/// every sweep.
pub fn deposit<R: Rng>(
    layer: &mut Layer,
    params: &DepositionParams,
    rng: &mut R,
    mut progress: impl FnMut(u64, f64, f64),
) -> Result<DepositionOutcome> {
    params.check()?;
    let n = layer.grains.len();
    if n == 0 {
        return invalid("the layer holds no particles");
    }
    if params.energy.gravity {
        if let Some((i, g)) = layer
            .grains
            .iter()
            .enumerate()
            .find(|(_, g)| g.buoyant_weight_n.is_nan() || g.buoyant_weight_n <= 0.0)
        {
            return invalid(format!(
                "particle {i} (species {}) is not heavier than the fluid (buoyant weight {} N): \
                 it would never settle",
                g.species, g.buoyant_weight_n
            ));
        }
    } else if !params.energy.drag {
        return invalid("neither gravity nor drag is on: no move can lower the energy");
    }
    let mut cells = layer.cells();
    let mut positions: Vec<Vector3<f64>> = layer.poses.iter().map(|p| p.position).collect();
    let mut out = DepositionOutcome {
        sweeps: 0,
        moves: 0,
        accepted: 0,
        converged: false,
        first_displacement_m: 0.0,
        prefilters: PrefilterCounts::default(),
        history: Vec::new(),
    };
    let mut v = 0.0f64;
    let mut window_sum = 0.0f64;
    for sweep in 1..=params.max_sweeps {
        let mut displacement = 0.0f64;
        let mut accepted = 0u64;
        for j in 0..n {
            let g = layer.grains[j];
            let m = moves::draw(rng, params.k_max_m2, &g.inertia_per_volume_m2);
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
            super::cells::wrap_xy(&mut trial.position, layer.box_side_m);
            if !layer.fits(
                &cells,
                &positions,
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
            positions[j] = trial.position;
            cells.moved(j, &trial.position);
            accepted += 1;
            displacement += t.norm();
        }
        let mean = displacement / n as f64;
        out.sweeps = sweep;
        out.moves += n as u64;
        out.accepted += accepted;
        out.history.push(SweepRecord {
            sweep,
            mean_displacement_m: mean,
            acceptance: accepted as f64 / n as f64,
            drainage_speed_m_s: v,
        });
        if sweep == 1 {
            out.first_displacement_m = mean;
            if mean == 0.0 {
                return invalid(
                    "no particle could move in the first sweep: the start is jammed or no \
                     energy term can be lowered",
                );
            }
        }
        let stop = params.stop_fraction * out.first_displacement_m;
        // Running sum over the window (exact re-summation every 4096 sweeps against drift).
        window_sum += mean;
        if sweep > params.stop_window {
            window_sum -=
                out.history[(sweep - params.stop_window - 1) as usize].mean_displacement_m;
        }
        let w = params.stop_window.min(sweep) as usize;
        if sweep % 4096 == 0 {
            window_sum = out.history[out.history.len() - w..]
                .iter()
                .map(|h| h.mean_displacement_m)
                .sum::<f64>();
        }
        let recent = window_sum / w as f64;
        progress(sweep, recent, stop);
        if sweep >= params.stop_window.max(2) && recent < stop {
            out.converged = true;
            break;
        }
        v = mean / params.time_unit_s;
    }
    Ok(out)
}
