//! The dynamic state of a [`Filter`] run as plain data, every f64 kept as its IEEE bits, so
//! that a run restored from it continues bitwise as the uninterrupted run would: per particle
//! its position, deepest depth, fate and the word position of its own ChaCha8 stream, and the
//! run's step count (the time is steps x dt). The bed, flow, field, particles' feed and random
//! streams' seeds follow from the setup; the streams are checked against it.

use super::engine::{Fate, Filter, Tracer};
use crate::error::invalid;
use crate::Result;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// One particle's fate, floats as bits.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum FateBits {
    Inside,
    Captured {
        fibre: usize,
        time_s: u64,
        position: [u64; 3],
    },
    Passed {
        time_s: u64,
    },
}

/// One particle (see the module note).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TracerState {
    pub position: [u64; 3],
    pub max_depth_m: u64,
    pub fate: FateBits,
    /// The stream's word position (u128) as (high, low) halves.
    pub rng_word_pos: [u64; 2],
}

/// The state of a filter run (see the module note).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FilterState {
    pub steps: u64,
    pub tracers: Vec<TracerState>,
}

fn bits(v: &Vector3<f64>) -> [u64; 3] {
    [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]
}

fn vector(b: &[u64; 3]) -> Vector3<f64> {
    Vector3::new(
        f64::from_bits(b[0]),
        f64::from_bits(b[1]),
        f64::from_bits(b[2]),
    )
}

impl Filter {
    /// The dynamic state, exactly.
    pub fn save_state(&self) -> FilterState {
        let tracers = self
            .tracers()
            .iter()
            .map(|t| {
                let pos = t.rng_word_pos();
                TracerState {
                    position: bits(&t.position),
                    max_depth_m: t.max_depth_m.to_bits(),
                    fate: match t.fate {
                        Fate::Inside => FateBits::Inside,
                        Fate::Captured {
                            fibre,
                            time_s,
                            position,
                        } => FateBits::Captured {
                            fibre,
                            time_s: time_s.to_bits(),
                            position: bits(&position),
                        },
                        Fate::Passed { time_s } => FateBits::Passed {
                            time_s: time_s.to_bits(),
                        },
                    },
                    rng_word_pos: [(pos >> 64) as u64, pos as u64],
                }
            })
            .collect();
        FilterState {
            steps: self.steps(),
            tracers,
        }
    }

    /// Replaces the particles and the step count by those of `s`, saved from a run of the
    /// same setup (this filter as [`Filter::new`] built it: the particles' streams are the
    /// setup's, positioned at the saved words).
    pub fn load_state(&mut self, s: &FilterState) -> Result<()> {
        let n = self.tracers().len();
        if s.tracers.len() != n {
            return invalid(format!(
                "checkpoint: {} particles, the setup feeds {n}",
                s.tracers.len()
            ));
        }
        let fibres = self.bed().fibres().len();
        let mut tracers: Vec<Tracer> = self.tracers().to_vec();
        for (i, (t, st)) in tracers.iter_mut().zip(&s.tracers).enumerate() {
            let position = vector(&st.position);
            let max_depth_m = f64::from_bits(st.max_depth_m);
            t.fate = match st.fate {
                FateBits::Inside => Fate::Inside,
                FateBits::Captured {
                    fibre,
                    time_s,
                    position,
                } => {
                    if fibre >= fibres {
                        return invalid(format!(
                            "checkpoint: particle {i} captured by fibre {fibre}, the bed has \
                             {fibres}"
                        ));
                    }
                    Fate::Captured {
                        fibre,
                        time_s: f64::from_bits(time_s),
                        position: vector(&position),
                    }
                }
                FateBits::Passed { time_s } => Fate::Passed {
                    time_s: f64::from_bits(time_s),
                },
            };
            if !(position.iter().all(|x| x.is_finite()) && max_depth_m.is_finite()) {
                return invalid(format!(
                    "checkpoint: particle {i}: non-finite position or depth"
                ));
            }
            t.position = position;
            t.max_depth_m = max_depth_m;
            t.set_rng_word_pos(((st.rng_word_pos[0] as u128) << 64) | st.rng_word_pos[1] as u128);
        }
        self.restore(tracers, s.steps);
        Ok(())
    }
}
