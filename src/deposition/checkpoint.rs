//! The complete dynamic state of a [`Deposition`] as plain data, every f64 kept as its IEEE
//! bits, so that a run restored from it continues bitwise as the uninterrupted run would:
//! every grain's pose, the film height, the run's random stream (seed, stream and word
//! position of its ChaCha8), the cell list's layering and member order (which decide the
//! prefilter counts), the drainage speed of the next sweep, the stop rule's window sums, means
//! and reference sweep, and the record of the sweeps so far. What the setup fixes (the grains,
//! their sizes drawn from the run's stream before the start was built, the moves and the stop
//! rule) is rebuilt from the setup and checked against the stored values.

use super::engine::{Deposition, DepositionOutcome, SweepRecord};
use super::grain::GrainPose;
use super::overlap::PrefilterCounts;
use super::setup::Setup;
use super::Layer;
use crate::error::invalid;
use crate::Result;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// One sweep's record: (sweep, mean displacement, acceptance, drainage speed), floats as bits.
type RecordBits = (u64, u64, u64, u64);

/// The state of a deposition run (see the module note).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DepositionState {
    /// Grain volumes (bits): checked against the grains the setup draws.
    pub volume_m3: Vec<u64>,
    pub film_height_m: u64,
    pub position: Vec<[u64; 3]>,
    /// Body-to-world unit quaternions as (i, j, k, w).
    pub orientation: Vec<[u64; 4]>,
    pub rng_seed: [u8; 32],
    pub rng_stream: u64,
    /// The stream's word position (u128) as (high, low) halves.
    pub rng_word_pos: [u64; 2],
    pub cells_z_layers: usize,
    pub cell_z_m: u64,
    pub cell_members: Vec<Vec<u32>>,
    pub v_m_s: u64,
    pub window_sum_m: u64,
    pub recent_m: u64,
    /// The accepted-move rule's window sum and mean (bits); absent in checkpoints written
    /// before that rule, then summed again from the history.
    #[serde(default)]
    pub window_accepted: Option<u64>,
    #[serde(default)]
    pub recent_acceptance: Option<u64>,
    pub reference_sweep: u64,
    pub sweeps: u64,
    pub moves: u64,
    pub accepted: u64,
    pub converged: bool,
    pub first_displacement_m: u64,
    /// Bounding spheres, sphere pairs, inscribed spheres, Perram-Wertheim.
    pub prefilters: [u64; 4],
    pub history: Vec<RecordBits>,
}

fn v3(v: &Vector3<f64>) -> [u64; 3] {
    [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]
}

impl Deposition {
    /// The dynamic state, exactly.
    pub fn save_state(&self) -> DepositionState {
        let pos = self.rng.get_word_pos();
        let (n_z, cell_z_m, members) = self.cells.history();
        let o = &self.outcome;
        let p = &o.prefilters;
        DepositionState {
            volume_m3: self
                .layer
                .grains
                .iter()
                .map(|g| g.volume_m3.to_bits())
                .collect(),
            film_height_m: self.layer.film_height_m.to_bits(),
            position: self.layer.poses.iter().map(|p| v3(&p.position)).collect(),
            orientation: self
                .layer
                .poses
                .iter()
                .map(|p| {
                    let q = p.orientation.quaternion();
                    [q.i, q.j, q.k, q.w].map(f64::to_bits)
                })
                .collect(),
            rng_seed: self.rng.get_seed(),
            rng_stream: self.rng.get_stream(),
            rng_word_pos: [(pos >> 64) as u64, pos as u64],
            cells_z_layers: n_z,
            cell_z_m: cell_z_m.to_bits(),
            cell_members: members.to_vec(),
            v_m_s: self.v.to_bits(),
            window_sum_m: self.window_sum.to_bits(),
            recent_m: self.recent_m.to_bits(),
            window_accepted: Some(self.window_accepted.to_bits()),
            recent_acceptance: Some(self.recent_acceptance.to_bits()),
            reference_sweep: self.reference_sweep,
            sweeps: o.sweeps,
            moves: o.moves,
            accepted: o.accepted,
            converged: o.converged,
            first_displacement_m: o.first_displacement_m.to_bits(),
            prefilters: [
                p.bounding_spheres,
                p.sphere_pairs,
                p.inscribed_spheres,
                p.perram_wertheim,
            ],
            history: o
                .history
                .iter()
                .map(|h| {
                    (
                        h.sweep,
                        h.mean_displacement_m.to_bits(),
                        h.acceptance.to_bits(),
                        h.drainage_speed_m_s.to_bits(),
                    )
                })
                .collect(),
        }
    }

    /// Run `run` of `setup` at the state `s` saved from it: the grains are drawn again from
    /// the run's stream (the start is not rebuilt), and must have the stored volumes bitwise.
    pub fn restore(setup: &Setup, run: usize, s: &DepositionState) -> Result<Deposition> {
        setup.check()?;
        let mut rng = setup.run_rng(run);
        let grains = setup.grains(&mut rng)?;
        let n = grains.len();
        let per_particle = [
            ("volume_m3", s.volume_m3.len()),
            ("position", s.position.len()),
            ("orientation", s.orientation.len()),
        ];
        if let Some((name, len)) = per_particle.iter().find(|(_, len)| *len != n) {
            return invalid(format!(
                "checkpoint: {len} entries in `{name}`, but the setup has {n} particles"
            ));
        }
        if let Some(i) = (0..n).find(|&i| s.volume_m3[i] != grains[i].volume_m3.to_bits()) {
            return invalid(format!(
                "checkpoint: volume of particle {i} is {} m^3, the setup gives {} m^3",
                f64::from_bits(s.volume_m3[i]),
                grains[i].volume_m3
            ));
        }
        if s.rng_seed != rng.get_seed() {
            return invalid(format!(
                "checkpoint: the random stream is not that of run {run} of the setup's seed"
            ));
        }
        if s.history.len() as u64 != s.sweeps {
            return invalid(format!(
                "checkpoint: {} sweep records for {} sweeps",
                s.history.len(),
                s.sweeps
            ));
        }
        let f = f64::from_bits;
        let poses = s
            .position
            .iter()
            .zip(&s.orientation)
            .map(|(p, q)| GrainPose {
                position: Vector3::new(f(p[0]), f(p[1]), f(p[2])),
                orientation: UnitQuaternion::new_unchecked(Quaternion::new(
                    f(q[3]),
                    f(q[0]),
                    f(q[1]),
                    f(q[2]),
                )),
            })
            .collect();
        let layer = Layer {
            grains,
            poses,
            box_side_m: setup.box_side_m,
            film_height_m: f(s.film_height_m),
        };
        let mut d = Deposition::from_layer(layer, setup.moves, setup.stop, rng)?;
        d.rng.set_stream(s.rng_stream);
        d.rng
            .set_word_pos(((s.rng_word_pos[0] as u128) << 64) | s.rng_word_pos[1] as u128);
        d.cells
            .restore_history(
                s.cells_z_layers,
                f(s.cell_z_m),
                s.cell_members.clone(),
                &d.positions,
            )
            .map_err(|e| crate::Error::InvalidInput(format!("checkpoint: cell list: {e}")))?;
        d.v = f(s.v_m_s);
        d.window_sum = f(s.window_sum_m);
        d.recent_m = f(s.recent_m);
        d.reference_sweep = s.reference_sweep;
        let p = s.prefilters;
        d.outcome = DepositionOutcome {
            sweeps: s.sweeps,
            moves: s.moves,
            accepted: s.accepted,
            converged: s.converged,
            first_displacement_m: f(s.first_displacement_m),
            prefilters: PrefilterCounts {
                bounding_spheres: p[0],
                sphere_pairs: p[1],
                inscribed_spheres: p[2],
                perram_wertheim: p[3],
            },
            history: s
                .history
                .iter()
                .map(|h| SweepRecord {
                    sweep: h.0,
                    mean_displacement_m: f(h.1),
                    acceptance: f(h.2),
                    drainage_speed_m_s: f(h.3),
                })
                .collect(),
        };
        let w = (d.stop.window.min(s.sweeps) as usize).min(d.outcome.history.len());
        let summed = d.outcome.history[d.outcome.history.len() - w..]
            .iter()
            .map(|h| h.acceptance)
            .sum::<f64>();
        d.window_accepted = s.window_accepted.map_or(summed, f);
        d.recent_acceptance = s.recent_acceptance.map_or(summed / w.max(1) as f64, f);
        let finite = [
            d.v,
            d.window_sum,
            d.recent_m,
            d.window_accepted,
            d.recent_acceptance,
        ]
        .iter()
        .all(|x| x.is_finite())
            && d.layer.poses.iter().all(|p| {
                p.position.iter().all(|x| x.is_finite())
                    && p.orientation.coords.iter().all(|x| x.is_finite())
            });
        if !finite {
            return invalid("checkpoint: non-finite pose or stop-rule state");
        }
        Ok(d)
    }
}
