//! Monte-Carlo deposition of ellipsoidal pigments into a coating layer (seed 000: Vidal, Zou &
//! Uesaka 2004, appendices A and B).
//!
//! The wet film is a square box of side L, periodic in x and y, on a flat hard substrate at
//! z = 0, open at the top. Particles are moved one at a time by random translations and
//! rotations about their body axes under one kinetic-energy budget ([`moves`], eq. A12-A16);
//! a move is accepted iff it creates no overlap ([`overlap`]) and lowers the total energy
//! ([`energy`]): buoyant gravity plus the drag potential E_d = sum C_j mu V z_j (eq. A2, A3,
//! A11), with V the mean displacement of the previous sweep per time unit. The run stops when
//! the mean displacement per sweep falls below a fraction of the first sweep's ([`engine`],
//! [`driver`]).
//! The start is built by [`film`]: the pigment volume fraction from the solids content
//! (Table B1), random sequential addition, and above its limit, growth of the particles by
//! hard-core Monte Carlo without gravity.
//!
//! Lengths in metres, energies in joules, everywhere.
//!
//! The door: a [`Setup`] (`setup.rs`) describes the runs; [`Deposition::new`] builds run k's
//! start; [`Deposition::step`] is one sweep; [`driver::run`] sweeps to the end with progress
//! and stop hooks ([`crate::driver::Hooks`]) and [`driver::run_one`] does a whole run;
//! [`checkpoint`] saves a run's state and [`Deposition::restore`] continues it bitwise.

pub mod cells;
pub mod checkpoint;
pub mod driver;
pub mod energy;
pub mod engine;
pub mod film;
pub mod grain;
pub mod measure;
pub mod moves;
pub mod overlap;
mod setup;
pub mod support;

pub use engine::{Deposition, DepositionOutcome, SweepRecord};
pub use setup::{run_seed, Moves, Setup, SizeLaw, Species, StopRule};

use cells::Cells;
use grain::{Grain, GrainPose};
use overlap::{pair_overlaps, PrefilterCounts};

/// A layer of posed grains in the deposition box.
#[derive(Debug, Clone)]
pub struct Layer {
    pub grains: Vec<Grain>,
    pub poses: Vec<GrainPose>,
    /// Side of the periodic square box, m.
    pub box_side_m: f64,
    /// Height of the wet film at the start, m.
    pub film_height_m: f64,
}

impl Layer {
    /// Twice the largest bounding radius: no two grains farther apart can overlap, m.
    pub fn reach_m(&self) -> f64 {
        2.0 * self
            .grains
            .iter()
            .map(|g| g.outer_radius_m)
            .fold(0.0, f64::max)
    }

    /// A cell list over the current positions.
    pub fn cells(&self) -> Cells {
        let top = self
            .poses
            .iter()
            .map(|p| p.position.z)
            .fold(self.film_height_m, f64::max);
        let pos: Vec<_> = self.poses.iter().map(|p| p.position).collect();
        Cells::new(self.box_side_m, self.reach_m(), top, &pos)
    }

    /// Would grain `i` at `pose` stay clear of the substrate, of the lid at `lid_m` (if any)
    /// and of every other grain? With `scales`, every grain j is scaled by `scales[j]` about
    /// its centre and grain i by `scale`; without, all are full size.
    #[allow(clippy::too_many_arguments)]
    pub fn fits(
        &self,
        cells: &Cells,
        positions: &[nalgebra::Vector3<f64>],
        i: usize,
        pose: &GrainPose,
        scale: f64,
        scales: Option<&[f64]>,
        lid_m: Option<f64>,
        counts: &mut PrefilterCounts,
    ) -> bool {
        let g = &self.grains[i];
        let hh = scale * g.half_height(&pose.orientation);
        if pose.position.z - hh < 0.0 {
            return false;
        }
        if let Some(lid) = lid_m {
            if pose.position.z + hh > lid {
                return false;
            }
        }
        !cells.any_near(i, &pose.position, positions, |j, d| {
            pair_overlaps(
                g,
                &pose.orientation,
                scale,
                &self.grains[j],
                &self.poses[j].orientation,
                scales.map_or(1.0, |s| s[j]),
                &d,
                counts,
            )
        })
    }

    /// Total grain volume, m^3.
    pub fn solid_volume_m3(&self) -> f64 {
        self.grains.iter().map(|g| g.volume_m3).sum()
    }
}
